# kinematics: Duckietown's inverse kinematics core, kinematics_node (included from CMakeLists.txt).
target_sources(autocal_core PRIVATE src/core/wheels/kinematics.cpp)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_kinematics SOURCES test/wheels/test_kinematics.cpp LIBS autocal_core)
endif()
