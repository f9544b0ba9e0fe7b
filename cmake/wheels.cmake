# wheels: AprilTag detection and pose, heading, the trim estimator, wheel_calibration_node (included from CMakeLists.txt).
