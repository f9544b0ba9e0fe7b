# report: the run's report (report.png, summary.yaml) and run_report_node, which watches a whole
# calibration run and ends it (included from CMakeLists.txt).
target_sources(autocal_report PRIVATE src/core/report/run_record.cpp src/core/report/paths.cpp
  src/core/report/gates.cpp src/core/report/sheet.cpp src/core/report/summary.cpp src/core/report/camera_view.cpp)

# replay: a recorded run recomputed with no master (the replay Stages fed from a bag).
target_sources(autocal_replay PRIVATE src/core/replay/run_replay.cpp)
add_executable(replay src/nodes/replay/replay_main.cpp)
target_link_libraries(replay autocal_ros)
autocal_ros_target(replay)

add_executable(run_report_node
  src/nodes/run_report/run_report_node.cpp
  src/nodes/run_report/run_report_node_main.cpp)
target_link_libraries(run_report_node autocal_ros)
autocal_ros_target(run_report_node)

# Ends sim_fleet.launch when every robot's run ended; says which failed.
add_executable(fleet_report_node src/nodes/run_report/fleet_report_main.cpp)
target_link_libraries(fleet_report_node autocal_ros)
autocal_ros_target(fleet_report_node)

# The camera image with detections for RViz (raw: Debian has no compressed image_transport plugin).
add_executable(camera_view_node
  src/nodes/run_report/camera_view_node.cpp
  src/nodes/run_report/camera_view_node_main.cpp)
target_link_libraries(camera_view_node autocal_ros)
autocal_ros_target(camera_view_node)

if(CATKIN_ENABLE_TESTING)
  add_rostest_gtest(test_camera_view_node test/report/camera_view_node.test
    test/report/test_camera_view_node.cpp)
  target_link_libraries(test_camera_view_node autocal_ros GTest::gtest)
  target_include_directories(test_camera_view_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_camera_view_node)
  add_dependencies(test_camera_view_node camera_view_node)
endif()

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_run_report SOURCES test/report/test_run_report.cpp LIBS autocal_core)
  # calibrate_sim.launch rviz:=true parses (roslaunch --nodes: nothing starts, no RViz needed) and
  # config/autocal.rviz shows the nodes' topics.
  autocal_core_gtest(test_rviz_launch SOURCES test/report/test_rviz_launch.cpp LIBS autocal_core)
  add_dependencies(test_rviz_launch camera_view_node)
endif()

if(CATKIN_ENABLE_TESTING)
  # The node's diagnostics and believed path, with the stages played by the test (no simulator).
  add_rostest_gtest(test_run_report_node test/report/run_report_node.test
    test/report/test_run_report_node.cpp)
  target_link_libraries(test_run_report_node autocal_core autocal_ros GTest::gtest)
  target_include_directories(test_run_report_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_run_report_node)
  add_dependencies(test_run_report_node run_report_node)
endif()

if(CATKIN_ENABLE_TESTING)
  # SIGKILL of a stage's node mid-run (run_kill.test), judged by the simulator's truth.
  add_executable(test_run_kill EXCLUDE_FROM_ALL test/report/test_run_kill.cpp)
  target_link_libraries(test_run_kill autocal_core autocal_ros GTest::gtest)
  target_include_directories(test_run_kill PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_run_kill)
  add_dependencies(tests test_run_kill)
  add_rostest(test/report/run_kill.test ARGS stage:=camera
    DEPENDENCIES test_run_kill run_report_node camera_calibration_node sim_node)
  add_rostest(test/report/run_kill.test ARGS stage:=wheels
    DEPENDENCIES test_run_kill run_report_node wheel_calibration_node sim_node)
  add_rostest(test/report/run_kill.test ARGS stage:=odometry
    DEPENDENCIES test_run_kill run_report_node odometry_calibration_node sim_node)

  # A calibration_root no one can write: every stage refuses it before the robot moves.
  add_executable(test_run_unwritable EXCLUDE_FROM_ALL test/report/test_run_unwritable.cpp)
  target_link_libraries(test_run_unwritable autocal_core autocal_ros GTest::gtest)
  target_include_directories(test_run_unwritable PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_run_unwritable)
  add_dependencies(tests test_run_unwritable)
  add_rostest(test/report/run_unwritable.test
    DEPENDENCIES test_run_unwritable run_report_node camera_calibration_node
    wheel_calibration_node sim_node)
  add_rostest(test/report/run_unwritable.test
    ARGS veh:=unitslip calibration_root:=/tmp/autocal_run_unit_slip unit_slip:=true
    DEPENDENCIES test_run_unwritable run_report_node camera_calibration_node
    wheel_calibration_node sim_node)

  # A robot config with a typo: the run's report names the simulator's reason.
  add_executable(test_run_bad_config EXCLUDE_FROM_ALL test/report/test_run_bad_config.cpp)
  target_link_libraries(test_run_bad_config autocal_core autocal_ros GTest::gtest)
  target_include_directories(test_run_bad_config PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_run_bad_config)
  add_dependencies(tests test_run_bad_config)
  add_rostest(test/report/run_bad_config.test
    DEPENDENCIES test_run_bad_config run_report_node camera_calibration_node
    wheel_calibration_node sim_node)
endif()

if(CATKIN_ENABLE_TESTING)
  # The whole run with the odometry stage (calibrate_run.test), judged by the simulator's truth.
  add_executable(test_calibrate_run EXCLUDE_FROM_ALL test/report/test_calibrate_run.cpp)
  target_link_libraries(test_calibrate_run autocal_test_support autocal_core autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_calibrate_run PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_calibrate_run)
  add_dependencies(tests test_calibrate_run)
  # About 2 min at real_time_factor 0 (doc/calibration_run.md); in make test since the
  # odometry node tests run at 0 in lockstep too and left the time for it.
  add_rostest(test/report/calibrate_run.test
    DEPENDENCIES test_calibrate_run camera_calibration_node wheel_calibration_node
                 odometry_calibration_node run_report_node sim_node)
  # Robot mode (real_time_factor 1, robot_real.yaml): the camera and wheel stages, about 3.5 min.
  add_rostest(test/report/calibrate_run_robot.test
    DEPENDENCIES test_calibrate_run camera_calibration_node wheel_calibration_node
                 run_report_node sim_node)
endif()

if(CATKIN_ENABLE_TESTING)
  # Record a simulated calibration, replay it with no robot and no master, compare (replay.test).
  add_executable(test_replay EXCLUDE_FROM_ALL test/report/test_replay.cpp)
  target_link_libraries(test_replay autocal_test_support autocal_core autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_replay PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_replay)
  add_dependencies(tests test_replay)
  add_rostest(test/report/replay.test
    DEPENDENCIES test_replay replay run_report_node camera_calibration_node wheel_calibration_node sim_node)
endif()

if(CATKIN_ENABLE_TESTING)
  # Two different robots in one simulator (sim_fleet.test), each judged by its own truth.
  add_executable(test_sim_fleet EXCLUDE_FROM_ALL test/report/test_sim_fleet.cpp)
  target_link_libraries(test_sim_fleet autocal_test_support autocal_core autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_sim_fleet PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_sim_fleet)
  add_dependencies(tests test_sim_fleet)
  add_rostest(test/report/sim_fleet.test
    DEPENDENCIES test_sim_fleet fleet_report_node run_report_node camera_calibration_node
    wheel_calibration_node sim_node)
endif()
