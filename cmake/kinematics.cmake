# kinematics: Duckietown's inverse kinematics core, kinematics_node (included from CMakeLists.txt).
target_sources(autocal_wheels PRIVATE src/core/wheels/kinematics.cpp)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_kinematics SOURCES test/wheels/test_kinematics.cpp LIBS autocal_core)
endif()

# The robot's kinematics node: car_cmd in, wheels_cmd out, the kinematics file's parameters.
add_executable(kinematics_node
  src/nodes/kinematics/kinematics_node.cpp
  src/nodes/kinematics/kinematics_node_main.cpp)
target_link_libraries(kinematics_node autocal_ros)
autocal_ros_target(kinematics_node)
install(TARGETS kinematics_node RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  # The node end to end with a master: the test starts the node on its own files (it needs a file
  # in place before the node starts, and a fresh one per case) and checks topics, parameters, the
  # service, the stop on SIGTERM and the exit code of a malformed file.
  add_rostest_gtest(test_kinematics_node test/wheels/kinematics_node.test
    test/wheels/test_kinematics_node.cpp)
  target_link_libraries(test_kinematics_node autocal_ros GTest::gtest)
  target_include_directories(test_kinematics_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_kinematics_node)
  target_compile_definitions(test_kinematics_node PRIVATE
    KINEMATICS_NODE_BIN="$<TARGET_FILE:kinematics_node>")
  add_dependencies(test_kinematics_node kinematics_node)
endif()
