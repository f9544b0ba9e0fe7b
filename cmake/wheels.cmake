# wheels: the tags' heading, the trim estimator, the motor fit, the wheel stage (autocal_wheels),
# wheel_calibration_node (included from CMakeLists.txt).
target_sources(autocal_wheels PRIVATE
  src/core/wheels/tag_heading.cpp
  src/core/wheels/trim_estimator.cpp
  src/core/wheels/motor_fit.cpp
  src/core/wheels/wheel_run.cpp
  src/core/wheels/wheel_run_output.cpp
  src/core/wheels/wheel_replay.cpp)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_trim_estimator SOURCES test/wheels/test_trim_estimator.cpp LIBS autocal_core)
  autocal_core_gtest(test_tag_heading SOURCES test/wheels/test_tag_heading.cpp LIBS autocal_core)
  # Detection and heading on rendered frames, against the simulator's true pose.
  autocal_core_gtest(test_tag_heading_in_sim SOURCES test/wheels/test_tag_heading_in_sim.cpp
                     LIBS autocal_core autocal_sim_core)
endif()

if(CATKIN_ENABLE_TESTING)
  target_sources(autocal_test_support PRIVATE test/support/wheels_in_sim.cpp)
  autocal_core_gtest(test_wheel_run_in_sim SOURCES test/wheels/test_wheel_run_in_sim.cpp
                     LIBS autocal_test_support autocal_core autocal_sim_core)
endif()

# The robot's wheel stage: aligns with the floor tags, iterates the trim, leaves the tag field.
add_executable(wheel_calibration_node
  src/nodes/wheel_calibration/wheel_calibration_node.cpp
  src/nodes/wheel_calibration/wheel_calibration_node_main.cpp)
target_link_libraries(wheel_calibration_node autocal_ros)
autocal_ros_target(wheel_calibration_node)

if(CATKIN_ENABLE_TESTING)
  # The camera and wheel stages end to end in the simulator (wheel_node.test), judged by the truth.
  add_executable(test_wheel_node EXCLUDE_FROM_ALL test/wheels/test_wheel_node.cpp)
  target_link_libraries(test_wheel_node autocal_test_support autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_wheel_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_wheel_node)
  add_dependencies(tests test_wheel_node)
  # Through ROS at real_time_factor 2 (the node keeps up with the simulator on 2 busy cores; the
  # motions' clocks start when their commands go out, so a late node lengthens nothing): the
  # default robot and one with the left motor 14 % stronger and a wide deadband.
  set(_wheel_deps test_wheel_node wheel_calibration_node camera_calibration_node sim_node)
  add_rostest(test/wheels/wheel_node.test DEPENDENCIES ${_wheel_deps})
  add_rostest(test/wheels/wheel_node.test ARGS veh:=trimp08
    robot_config:=${CMAKE_CURRENT_SOURCE_DIR}/sim/config/fleet/robot_trim_p08.yaml
    DEPENDENCIES ${_wheel_deps})
  # The one failure path: no tag in a full turn; the intrinsics missing.
  add_executable(test_wheel_node_fails EXCLUDE_FROM_ALL test/wheels/test_wheel_node_fails.cpp)
  target_link_libraries(test_wheel_node_fails autocal_core autocal_ros GTest::gtest)
  target_include_directories(test_wheel_node_fails PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_wheel_node_fails)
  add_dependencies(tests test_wheel_node_fails)
  add_rostest(test/wheels/wheel_node_fails.test
    DEPENDENCIES test_wheel_node_fails wheel_calibration_node sim_node)
  add_rostest(test/wheels/wheel_node_fails.test ARGS veh:=nointrinsics
    intrinsics_file:=/nonexistent/camera.yaml expect:=intrinsics
    DEPENDENCIES test_wheel_node_fails wheel_calibration_node sim_node)
endif()

# Duckietown's acceptance test automated: drive 2 m straight through the kinematics node, report the
# drift (the simulator's truth, or the user's tape measure).
target_sources(autocal_wheels PRIVATE src/core/wheels/straight_track.cpp)
add_executable(validate_straight
  src/nodes/validate_straight/validate_straight_node.cpp
  src/nodes/validate_straight/validate_straight_main.cpp)
target_link_libraries(validate_straight autocal_ros)
autocal_ros_target(validate_straight)
if(CATKIN_ENABLE_TESTING)
  add_executable(test_validate_straight EXCLUDE_FROM_ALL test/wheels/test_validate_straight.cpp)
  target_link_libraries(test_validate_straight autocal_test_support autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_validate_straight PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_validate_straight)
  add_dependencies(tests test_validate_straight)
  add_rostest(test/wheels/validate_straight.test
    DEPENDENCIES test_validate_straight validate_straight kinematics_node sim_node)
endif()

if(CATKIN_ENABLE_TESTING)
  # make bench: the wheel stage over robot configs, autocal vs the paper alone (scripts/bench/wheels.sh).
  add_executable(wheel_bench bench/wheel_bench.cpp)
  target_link_libraries(wheel_bench autocal_test_support autocal_core autocal_sim_core)
  target_include_directories(wheel_bench PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  target_compile_definitions(wheel_bench PRIVATE AUTOCAL_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
  set_target_properties(wheel_bench PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
endif()

# In-lane refinement (paper 000 §5.2): the core, and the node that runs it while the robot drives.
target_sources(autocal_wheels PRIVATE src/core/wheels/lane_refiner.cpp)
if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_lane_refiner SOURCES test/wheels/test_lane_refiner.cpp LIBS autocal_core)
  target_sources(autocal_test_support PRIVATE test/support/lane_in_sim.cpp)
  autocal_core_gtest(test_lane_refiner_in_sim SOURCES test/wheels/test_lane_refiner_in_sim.cpp
                     LIBS autocal_test_support autocal_core autocal_sim_core)
endif()
add_executable(lane_refinement_node
  src/nodes/lane_refinement/lane_refinement_node.cpp
  src/nodes/lane_refinement/lane_refinement_options.cpp
  src/nodes/lane_refinement/lane_refinement_node_main.cpp)
target_link_libraries(lane_refinement_node autocal_ros)
autocal_ros_target(lane_refinement_node)
if(CATKIN_ENABLE_TESTING)
  # One pass through ROS at real_time_factor 2 (stable_passes 1), judged by the truth.
  add_executable(test_lane_refinement_node EXCLUDE_FROM_ALL test/wheels/test_lane_refinement_node.cpp)
  target_link_libraries(test_lane_refinement_node autocal_sim_core autocal_ros GTest::gtest)
  target_include_directories(test_lane_refinement_node PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  autocal_ros_target(test_lane_refinement_node)
  add_dependencies(tests test_lane_refinement_node)
  add_rostest(test/wheels/lane_refinement.test
    DEPENDENCIES test_lane_refinement_node lane_refinement_node kinematics_node sim_node)
endif()
