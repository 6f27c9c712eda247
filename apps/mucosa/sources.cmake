target_sources(mucosa_cli PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/main.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cli_util.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_map.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_demo.cpp)
