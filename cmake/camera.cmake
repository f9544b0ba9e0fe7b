# camera: core sources, nodes, commands and tests (included from CMakeLists.txt).
target_sources(autocal_core PRIVATE
  src/core/camera/chessboard.cpp
  src/core/camera/view_selection.cpp
  src/core/camera/calibration.cpp)

if(CATKIN_ENABLE_TESTING)
  autocal_core_gtest(test_camera_real SOURCES test/camera/test_camera_real.cpp LIBS autocal_core)
endif()
