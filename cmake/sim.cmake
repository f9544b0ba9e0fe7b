# The simulator: ROS-free core sources, its node, and its tests (included from CMakeLists.txt).
target_sources(autocal_sim_core PRIVATE
  sim/src/config.cpp
  sim/src/camera_model.cpp
  sim/src/scene.cpp
  sim/src/ray_tracer.cpp
  sim/src/renderer.cpp
  sim/src/simulation.cpp
  sim/src/transport.cpp
  sim/src/floor_truth.cpp
  sim/src/projection_difference.cpp
  sim/src/straight_drift.cpp)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_sim_physics SOURCES test/sim/test_physics.cpp LIBS autocal_sim_core)
  autocal_core_gtest(test_sim_transport SOURCES test/sim/test_transport.cpp LIBS autocal_sim_core)
endif()

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_sim_renderer SOURCES test/sim/test_renderer.cpp LIBS autocal_sim_core)
endif()

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_sim_range_config SOURCES test/sim/test_range_and_config.cpp LIBS autocal_sim_core)
endif()

# The simulator node.
add_executable(sim_node sim/src/node/sim_node.cpp sim/src/node/sim_node_main.cpp sim/src/node/sim_robot.cpp
  sim/src/node/world_markers.cpp)
target_link_libraries(sim_node autocal_sim_core autocal_ros)
autocal_ros_target(sim_node)

if(CATKIN_ENABLE_TESTING)
  # rostests of the node: one test executable, each .test file runs some of its cases.
  add_rostest_gtest(test_sim_node test/sim/sim_topics.test test/sim/test_sim_node.cpp)
  target_link_libraries(test_sim_node autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_sim_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_sim_node)
  target_compile_definitions(test_sim_node PRIVATE
    AUTOCAL_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}" SIM_NODE_BIN="$<TARGET_FILE:sim_node>")
  add_dependencies(test_sim_node sim_node)
  add_rostest(test/sim/sim_drive.test DEPENDENCIES test_sim_node sim_node)
  add_rostest(test/sim/sim_bad_config.test DEPENDENCIES test_sim_node sim_node)
  add_rostest(test/sim/sim_viz.test DEPENDENCIES test_sim_node sim_node)
  add_rostest(test/sim/sim_fleet_frames.test DEPENDENCIES test_sim_node sim_node)
  add_rostest(test/sim/sim_transport.test DEPENDENCIES test_sim_node sim_node)
endif()

# make bench: render time and real-time factor (ROS-free).
add_executable(sim_bench bench/sim_bench.cpp)
target_link_libraries(sim_bench autocal_sim_core)
set_target_properties(sim_bench PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)

# Validation tool: a calibration's camera_info YAML next to the simulated robot's true lens.
add_executable(compare_camera src/nodes/sim_tools/compare_camera_main.cpp)
target_link_libraries(compare_camera autocal_sim_core autocal_ros)
autocal_ros_target(compare_camera)
add_executable(compare_extrinsics src/nodes/sim_tools/compare_extrinsics_main.cpp)
target_link_libraries(compare_extrinsics autocal_sim_core autocal_core)
set_target_properties(compare_extrinsics PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/lib/autocal)
add_executable(compare_wheels src/nodes/sim_tools/compare_wheels_main.cpp)
target_link_libraries(compare_wheels autocal_sim_core autocal_core)
set_target_properties(compare_wheels PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/lib/autocal)
