# Odometry calibration: dead reckoning, UMBmark, the UAH method (paper 002), the odometry file,
# the `umbmark` command and their tests (included from CMakeLists.txt).
target_sources(autocal_odometry PRIVATE
  src/core/odometry/dead_reckoning.cpp
  src/core/odometry/umbmark.cpp
  src/core/odometry/calibration_file.cpp
  src/core/odometry/uah.cpp)

# `rosrun autocal umbmark ...`: needs no ROS at all, so it links only the core. Built into the
# catkin devel space's lib/autocal, where rosrun finds it.
add_executable(umbmark src/nodes/umbmark_main.cpp)
target_link_libraries(umbmark autocal_core)
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
target_sources(autocal_odometry PRIVATE src/core/odometry/uah_run.cpp)
# ... and recomputed from a recording of them (odometry::replayUah, the passive mode).
target_sources(autocal_odometry PRIVATE src/core/odometry/uah_replay.cpp)

# The robot's UAH stage, and the simulator's tape measure for its straight runs.
add_executable(odometry_calibration_node
  src/nodes/odometry_calibration/odometry_calibration_node.cpp
  src/nodes/odometry_calibration/odometry_calibration_node_main.cpp)
target_link_libraries(odometry_calibration_node autocal_ros)
autocal_ros_target(odometry_calibration_node)
add_executable(straight_length_helper src/nodes/sim_tools/straight_length_helper.cpp)
target_link_libraries(straight_length_helper autocal_ros)
autocal_ros_target(straight_length_helper)
# ... and for UMBmark's return errors (method:=umbmark).
add_executable(umbmark_error_helper src/nodes/sim_tools/umbmark_error_helper.cpp)
target_link_libraries(umbmark_error_helper autocal_ros)
autocal_ros_target(umbmark_error_helper)

# `rosrun autocal uah --bag FILE --veh NAME ...`: the UAH result from a bag, no robot, no master
# (rosbag's C++ API and the ROS layer's message conversions).
add_executable(uah src/nodes/uah_main.cpp)
target_link_libraries(uah autocal_ros)
autocal_ros_target(uah)
install(TARGETS uah RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  # The UAH stage through ROS in the simulator (odometry_node.test), judged by the robot config.
  add_executable(test_odometry_node EXCLUDE_FROM_ALL test/odometry/test_odometry_node.cpp)
  target_link_libraries(test_odometry_node autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_odometry_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_odometry_node)
  add_dependencies(tests test_odometry_node)
  add_rostest(test/odometry/odometry_node.test
    DEPENDENCIES test_odometry_node odometry_calibration_node straight_length_helper sim_node)
  # More robots through ROS: a Duckiebot with its left wheel 2 % larger and
  # the larger robot (wheelbase 0.3 m, radius 0.05 m; told a nominal wheelbase of 0.29 m; 300 s of
  # sim time). All at real_time_factor 0, the simulator in lockstep (0.02 s) with the node.
  add_rostest(test/odometry/odometry_node.test
    ARGS veh:=left2 robot_config:=${CMAKE_CURRENT_SOURCE_DIR}/sim/config/fleet/robot_left2.yaml
    DEPENDENCIES test_odometry_node odometry_calibration_node straight_length_helper sim_node)
  add_rostest(test/odometry/odometry_node.test
    ARGS veh:=large robot_config:=${CMAKE_CURRENT_SOURCE_DIR}/sim/config/fleet/robot_large.yaml
         wheel_radius_m:=0.05 wheelbase_m:=0.29
    DEPENDENCIES test_odometry_node odometry_calibration_node straight_length_helper sim_node)
  # `uah --bag` on a recording of that run (uah_bag.test): against the live node and the truth,
  # and its bad-input paths on copies of the bag.
  add_executable(test_uah_bag EXCLUDE_FROM_ALL test/odometry/test_uah_bag.cpp)
  target_link_libraries(test_uah_bag autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_uah_bag PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  target_compile_definitions(test_uah_bag PRIVATE UAH_BINARY="$<TARGET_FILE:uah>"
    REPLAY_BINARY="$<TARGET_FILE:replay>")
  autocal_ros_target(test_uah_bag)
  add_dependencies(tests test_uah_bag)
  add_rostest(test/odometry/uah_bag.test
    DEPENDENCIES test_uah_bag uah replay odometry_calibration_node straight_length_helper sim_node)
endif()

# UMBmark driven by the robot (odometry::UmbmarkRun), its test on the simulator's core (beside UAH
# on the same robots) and the odometry benchmark (scripts/bench/odometry.sh).
target_sources(autocal_odometry PRIVATE src/core/odometry/umbmark_run.cpp)
if(CATKIN_ENABLE_TESTING)
  add_library(autocal_odometry_test_support STATIC test/support/odometry_in_sim.cpp)
  target_include_directories(autocal_odometry_test_support PUBLIC test)
  target_link_libraries(autocal_odometry_test_support PUBLIC autocal_test_support autocal_core
    autocal_sim_core)
  target_compile_definitions(autocal_odometry_test_support PRIVATE
    AUTOCAL_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
  autocal_core_gtest(test_umbmark_run_in_sim SOURCES test/odometry/test_umbmark_run_in_sim.cpp
                     LIBS autocal_odometry_test_support)
  autocal_core_gtest(test_uah_run_in_sim SOURCES test/odometry/test_uah_run_in_sim.cpp
                     LIBS autocal_odometry_test_support)
  # The passive mode (odometry::replayUah) on recordings of those runs.
  autocal_core_gtest(test_uah_replay SOURCES test/odometry/test_uah_replay.cpp
                     LIBS autocal_odometry_test_support)
endif()
if(CATKIN_ENABLE_TESTING)
  # method:=umbmark through ROS in the simulator (umbmark_node.test), judged by the robot config.
  add_executable(test_umbmark_node EXCLUDE_FROM_ALL test/odometry/test_umbmark_node.cpp)
  target_link_libraries(test_umbmark_node autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_umbmark_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_umbmark_node)
  add_dependencies(tests test_umbmark_node)
  add_rostest(test/odometry/umbmark_node.test
    DEPENDENCIES test_umbmark_node odometry_calibration_node umbmark_error_helper sim_node)
  # ... and its failure path: a return error in centimetres is refused, nothing written.
  add_rostest(test/odometry/umbmark_node_bad_error.test
    DEPENDENCIES test_umbmark_node odometry_calibration_node sim_node)
endif()
if(CATKIN_ENABLE_TESTING)
  # make bench: UAH vs UMBmark per robot config against the truth (scripts/bench/odometry.sh).
  add_executable(odometry_bench bench/odometry_bench.cpp)
  target_link_libraries(odometry_bench autocal_odometry_test_support)
  target_compile_definitions(odometry_bench PRIVATE AUTOCAL_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
  set_target_properties(odometry_bench PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
endif()
