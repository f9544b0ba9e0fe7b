# markers: AprilTag detection (autocal_markers), the `detect_tags` command, its tests and the tag
# detection benchmark (included from CMakeLists.txt).
target_sources(autocal_markers PRIVATE
  src/core/markers/tag_detector.cpp
  src/core/markers/detect_tags.cpp)

# `rosrun autocal detect_tags ...`: images need no ROS, but --bag reads rosbag, so it is on the ROS
# side. Built into the catkin devel space's lib/autocal, where rosrun finds it.
add_executable(detect_tags src/nodes/detect_tags_main.cpp)
target_link_libraries(detect_tags autocal_core)
autocal_ros_target(detect_tags)
install(TARGETS detect_tags RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  # Options, YAML and the camera_info reader, without images; the detector on tags drawn at known
  # corners.
  autocal_core_gtest(test_detect_tags SOURCES test/markers/test_detect_tags.cpp
                     test/markers/test_tag_detector.cpp LIBS autocal_core apriltag::apriltag)
  # The command end to end on the simulator's rendered floor tags (PNG folder and bag), against
  # the simulator's truth; and its bad-input exit codes.
  autocal_core_gtest(test_detect_tags_command SOURCES test/markers/test_detect_tags_command.cpp
                     LIBS autocal_ros autocal_sim_core autocal_core)
  autocal_ros_target(test_detect_tags_command)
  target_compile_definitions(test_detect_tags_command PRIVATE
    DETECT_TAGS_BINARY="$<TARGET_FILE:detect_tags>")
  add_dependencies(test_detect_tags_command detect_tags)
endif()

# Detection + pose speed per 640x480 frame, ours vs plain libapriltag (scripts/bench/tags.sh);
# ROS-free.
add_executable(bench_tag_detection test/markers/bench_tag_detection.cpp)
target_link_libraries(bench_tag_detection autocal_core autocal_sim_core)
target_compile_definitions(bench_tag_detection PRIVATE AUTOCAL_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
set_target_properties(bench_tag_detection PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
