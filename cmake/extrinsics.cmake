# extrinsics: the camera's ground projection (core sources, the offline command, tests; included
# from CMakeLists.txt).
target_sources(autocal_extrinsics PRIVATE
  src/core/extrinsics/ground_projection.cpp
  src/core/extrinsics/floor_board.cpp
  src/core/extrinsics/tag_mount.cpp
  src/core/extrinsics/extrinsics_file.cpp)

# The offline tool: Duckietown's board-on-the-floor procedure from one image (no ROS needed).
add_executable(calibrate_extrinsics src/nodes/calibrate_extrinsics_main.cpp)
target_link_libraries(calibrate_extrinsics autocal_core)
set_target_properties(calibrate_extrinsics PROPERTIES
  RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/lib/autocal)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_ground_projection SOURCES test/extrinsics/test_ground_projection.cpp
                     LIBS autocal_core)
  # On the simulator's rendered board, judged by its true mount.
  autocal_core_gtest(test_floor_board_in_sim SOURCES test/extrinsics/test_floor_board_in_sim.cpp
                     LIBS autocal_test_support autocal_core autocal_sim_core)
  # The mount from the floor tags alone, on rendered stills between turns and straight drives.
  autocal_core_gtest(test_tag_mount_in_sim SOURCES test/extrinsics/test_tag_mount_in_sim.cpp
                     LIBS autocal_test_support autocal_core autocal_sim_core)
  # The command end to end: a rendered image and a camera_info file in, the extrinsics file out.
  autocal_core_gtest(test_calibrate_extrinsics_tool
                     SOURCES test/extrinsics/test_calibrate_extrinsics_tool.cpp
                     LIBS autocal_test_support autocal_core autocal_sim_core)
  target_compile_definitions(test_calibrate_extrinsics_tool PRIVATE
                             AUTOCAL_TOOL="$<TARGET_FILE:calibrate_extrinsics>")
  add_dependencies(test_calibrate_extrinsics_tool calibrate_extrinsics)
endif()
