# wheels: AprilTag detection and pose, heading, the trim estimator, wheel_calibration_node (included from CMakeLists.txt).
target_sources(autocal_core PRIVATE
  src/core/markers/tag_detector.cpp
  src/core/wheels/tag_heading.cpp
  src/core/wheels/trim_estimator.cpp
  src/core/wheels/wheel_run.cpp)
# The wheel stage detects tags: AprilTag is linked where it is used.
target_link_libraries(autocal_core PUBLIC apriltag::apriltag)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_trim_estimator SOURCES test/wheels/test_trim_estimator.cpp LIBS autocal_core)
  autocal_core_gtest(test_tag_heading SOURCES test/wheels/test_tag_heading.cpp LIBS autocal_core)
  # Detection and heading on rendered frames, against the simulator's true pose.
  autocal_core_gtest(test_tag_heading_in_sim SOURCES test/wheels/test_tag_heading_in_sim.cpp
                     LIBS autocal_core autocal_sim_core)
endif()

if(CATKIN_ENABLE_TESTING)
  target_sources(autocal_test_support PRIVATE test/support/wheels_in_sim.cpp)
  autocal_core_gtest(test_wheel_run_in_sim SOURCES test/wheels/test_wheel_run_in_sim.cpp
                     LIBS autocal_test_support autocal_core autocal_sim_core)
endif()
