# The simulator: ROS-free core sources, its node, and its tests (included from CMakeLists.txt).
target_sources(autocal_sim_core PRIVATE
  sim/src/config.cpp
  sim/src/camera_model.cpp
  sim/src/scene.cpp
  sim/src/renderer.cpp
  sim/src/simulation.cpp)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_sim_physics SOURCES test/sim/test_physics.cpp LIBS autocal_sim_core)
endif()

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_sim_renderer SOURCES test/sim/test_renderer.cpp LIBS autocal_sim_core)
endif()

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_sim_range_config SOURCES test/sim/test_range_and_config.cpp LIBS autocal_sim_core)
endif()

# The simulator node.
add_executable(sim_node sim/src/node/sim_node.cpp sim/src/node/sim_node_main.cpp)
target_link_libraries(sim_node autocal_sim_core)
autocal_ros_target(sim_node)
