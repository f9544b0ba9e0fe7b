# kinematics: Duckietown's inverse kinematics core, kinematics_node (included from CMakeLists.txt).
