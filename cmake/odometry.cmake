# Odometry calibration: dead reckoning, UMBmark, the UAH method (paper 002), the odometry file,
# the `umbmark` command and their tests (included from CMakeLists.txt).
target_sources(autocal_core PRIVATE
  src/core/odometry/dead_reckoning.cpp
  src/core/odometry/umbmark.cpp
  src/core/odometry/calibration_file.cpp
  src/core/odometry/uah.cpp)

# `rosrun autocal umbmark ...`: needs no ROS at all, so it links only the core. Built into the
# catkin devel space's lib/autocal, where rosrun finds it.
add_executable(umbmark src/nodes/umbmark_main.cpp)
target_link_libraries(umbmark autocal_core)
target_compile_options(umbmark PRIVATE ${AUTOCAL_WARNINGS})
install(TARGETS umbmark RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_odometry_dead_reckoning
    SOURCES test/odometry/test_dead_reckoning.cpp LIBS autocal_core)
  autocal_core_gtest(test_odometry_umbmark
    SOURCES test/odometry/test_umbmark.cpp LIBS autocal_core autocal_test_support)
  autocal_core_gtest(test_odometry_uah
    SOURCES test/odometry/test_uah.cpp LIBS autocal_core)
  autocal_core_gtest(test_odometry_calibration_file
    SOURCES test/odometry/test_calibration_file.cpp LIBS autocal_core)
  autocal_core_gtest(test_odometry_umbmark_command
    SOURCES test/odometry/test_umbmark_command.cpp LIBS autocal_core)
  target_compile_definitions(test_odometry_umbmark_command PRIVATE
    UMBMARK_BINARY="$<TARGET_FILE:umbmark>")
  add_dependencies(test_odometry_umbmark_command umbmark)
endif()

# The UAH experiments driven by the robot (odometry::UahRun) and their test on the simulator's core.
target_sources(autocal_core PRIVATE src/core/odometry/uah_run.cpp)
if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_uah_run_in_sim SOURCES test/odometry/test_uah_run_in_sim.cpp
                     LIBS autocal_core autocal_sim_core)
endif()
