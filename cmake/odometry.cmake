# Odometry calibration: dead reckoning, UMBmark, the UAH method (paper 002), the odometry file,
# the `umbmark` command and their tests (included from CMakeLists.txt).
target_sources(autocal_core PRIVATE
  src/core/odometry/dead_reckoning.cpp
  src/core/odometry/umbmark.cpp)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_odometry_dead_reckoning
    SOURCES test/odometry/test_dead_reckoning.cpp LIBS autocal_core)
  autocal_core_gtest(test_odometry_umbmark
    SOURCES test/odometry/test_umbmark.cpp LIBS autocal_core)
endif()
