# report: the run's report (report.png, summary.yaml) and run_report_node, which watches a whole
# calibration run and ends it (included from CMakeLists.txt).
target_sources(autocal_core PRIVATE src/core/report/run_report.cpp)

add_executable(run_report_node
  src/nodes/run_report/run_report_node.cpp
  src/nodes/run_report/run_report_node_main.cpp)
target_link_libraries(run_report_node autocal_ros)
target_compile_options(run_report_node PRIVATE ${AUTOCAL_WARNINGS})
autocal_ros_target(run_report_node)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_run_report SOURCES test/report/test_run_report.cpp LIBS autocal_core)
endif()
