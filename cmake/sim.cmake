# sim: core sources, nodes, commands and tests (included from CMakeLists.txt).
