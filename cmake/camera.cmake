# camera: core sources, nodes, commands and tests (included from CMakeLists.txt).
target_sources(autocal_camera PRIVATE
  src/core/camera/chessboard.cpp
  src/core/camera/lens_refinement.cpp
  src/core/camera/view_selection.cpp
  src/core/camera/calibration.cpp
  src/core/camera/joint_fit.cpp
  src/core/camera/projection_uncertainty.cpp
  src/core/camera/camera_config.cpp
  src/core/camera/calibration_files.cpp
  src/core/camera/wheel_turn.cpp
  src/core/camera/sweep_controller.cpp
  src/core/camera/min_duty_probe.cpp
  src/core/camera/image_stillness.cpp
  src/core/camera/sweep_run.cpp
  src/core/camera/view_targets.cpp
  src/core/camera/sweep_replay.cpp
  src/core/camera/debug_image.cpp
  src/core/camera/focus_meter.cpp)

# The offline tool: image folder or bag in, camera_info YAML out.
add_executable(calibrate_camera src/nodes/calibrate_camera_main.cpp)
target_link_libraries(calibrate_camera autocal_ros)
target_compile_definitions(calibrate_camera PRIVATE AUTOCAL_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
autocal_ros_target(calibrate_camera)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_camera_real SOURCES test/camera/test_camera_real.cpp LIBS autocal_core)
endif()

if(CATKIN_ENABLE_TESTING)
  # One-wheel turns and the minimum moving duty probe against a scripted motor (no master).
  autocal_core_gtest(test_min_duty_probe SOURCES test/camera/test_min_duty_probe.cpp LIBS autocal_core)
  # The sweep controller against a scripted world of boards around the robot (no master).
  autocal_core_gtest(test_sweep_controller SOURCES test/camera/test_sweep_controller.cpp LIBS autocal_core)
endif()

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_camera_synthetic SOURCES test/camera/test_camera_synthetic.cpp
    LIBS autocal_core autocal_sim_core)
endif()

if(CATKIN_ENABLE_TESTING)
  # The command end to end (it writes bags, so it is a ROS-side test).
  autocal_core_gtest(test_calibrate_camera_tool SOURCES test/camera/test_calibrate_camera_tool.cpp LIBS autocal_core)
  autocal_ros_target(test_calibrate_camera_tool)
  target_compile_definitions(test_calibrate_camera_tool PRIVATE AUTOCAL_TOOL="$<TARGET_FILE:calibrate_camera>")
  add_dependencies(test_calibrate_camera_tool calibrate_camera)
endif()

# Detection speed benchmark (scripts/bench/camera.sh); ROS-free.
add_executable(bench_camera_detection test/camera/bench_camera_detection.cpp)
target_link_libraries(bench_camera_detection autocal_core autocal_sim_core)
target_compile_definitions(bench_camera_detection PRIVATE AUTOCAL_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
set_target_properties(bench_camera_detection PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)

if(CATKIN_ENABLE_TESTING)
  # The calibration core on the simulator's rendered frames, against the simulator's true lens.
  autocal_core_gtest(test_camera_in_sim SOURCES test/camera/test_camera_in_sim.cpp LIBS autocal_core autocal_sim_core)
endif()

if(CATKIN_ENABLE_TESTING)
  # The camera stage on the simulator's core (no ROS), against the simulator's true lens.
  target_sources(autocal_test_support PRIVATE test/support/sweep_in_sim.cpp)
  target_link_libraries(autocal_test_support PUBLIC autocal_sim_core)
  autocal_core_gtest(test_sweep_run_in_sim SOURCES test/camera/test_sweep_run_in_sim.cpp
                     LIBS autocal_test_support autocal_core autocal_sim_core)
endif()

# The robot's camera stage: turns past its boards and calibrates (camera::SweepRun on ROS).
add_executable(camera_calibration_node
  src/nodes/camera_calibration/camera_calibration_node.cpp
  src/nodes/camera_calibration/camera_calibration_node_main.cpp)
target_link_libraries(camera_calibration_node autocal_ros)
autocal_ros_target(camera_calibration_node)

# The focus assistant (paper 000 §6): the sharpness of the board in view while a person turns the
# lens ring.
add_executable(focus_node src/nodes/focus/focus_node.cpp src/nodes/focus/focus_node_main.cpp)
target_link_libraries(focus_node autocal_ros)
autocal_ros_target(focus_node)
if(CATKIN_ENABLE_TESTING)
  # The assistant in the simulator, in real time: the test turns the lens's ring through its peak.
  add_executable(test_focus_node EXCLUDE_FROM_ALL test/camera/test_focus_node.cpp)
  target_link_libraries(test_focus_node autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_focus_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_focus_node)
  add_dependencies(tests test_focus_node)
  add_rostest(test/camera/focus.test DEPENDENCIES test_focus_node focus_node sim_node)
endif()

if(CATKIN_ENABLE_TESTING)
  # The node end to end in the simulator (camera_node.test; arguments choose robot, world, outcome).
  add_executable(test_camera_node EXCLUDE_FROM_ALL test/camera/test_camera_node.cpp)
  target_link_libraries(test_camera_node autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_camera_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_camera_node)
  add_dependencies(tests test_camera_node)
  set(_cam_deps test_camera_node camera_calibration_node sim_node)
  add_rostest(test/camera/camera_node.test DEPENDENCIES ${_cam_deps})
  add_rostest(test/camera/camera_node.test ARGS veh:=badframes inject_bad_frames:=true
    DEPENDENCIES ${_cam_deps})
  add_rostest(test/camera/camera_node.test ARGS veh:=wide
    robot_config:=${CMAKE_CURRENT_SOURCE_DIR}/sim/config/fleet/robot_wide.yaml DEPENDENCIES ${_cam_deps})
  add_rostest(test/camera/camera_node.test ARGS veh:=narrow
    robot_config:=${CMAKE_CURRENT_SOURCE_DIR}/sim/config/fleet/robot_narrow.yaml DEPENDENCIES ${_cam_deps})
  add_rostest(test/camera/camera_node.test ARGS veh:=p95
    robot_config:=${CMAKE_CURRENT_SOURCE_DIR}/sim/config/fleet/robot_p95.yaml
    world_config:=${CMAKE_CURRENT_SOURCE_DIR}/sim/config/world_boards_b.yaml board:=8x6 square_m:=0.025
    DEPENDENCIES ${_cam_deps})
  add_rostest(test/camera/camera_node.test ARGS veh:=noboards
    world_config:=${CMAKE_CURRENT_SOURCE_DIR}/test/camera/world_no_boards.yaml
    expect:=failed failure_contains:=no_board_seen_in_a_full_turn DEPENDENCIES ${_cam_deps})
  add_rostest(test/camera/camera_node.test ARGS veh:=nocamera camera_enabled:=false
    expect:=failed failure_contains:=no_camera_frame DEPENDENCIES ${_cam_deps})
endif()

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_sweep_run SOURCES test/camera/test_sweep_run.cpp LIBS autocal_core)
  # Whether the image stands still, from two frames (phase correlation).
  autocal_core_gtest(test_image_stillness SOURCES test/camera/test_image_stillness.cpp
                     LIBS autocal_core)
endif()

if(CATKIN_ENABLE_TESTING)
  # make bench: the camera stage over the fleet's configs (scripts/bench/camera_sweep.sh).
  add_executable(camera_sweep_bench bench/camera_sweep_bench.cpp)
  target_link_libraries(camera_sweep_bench autocal_test_support autocal_core autocal_sim_core)
  target_compile_definitions(camera_sweep_bench PRIVATE AUTOCAL_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
  set_target_properties(camera_sweep_bench PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
endif()
