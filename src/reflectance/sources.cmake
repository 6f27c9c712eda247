target_sources(mucosa_core PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/normal_map.cpp
  ${CMAKE_CURRENT_LIST_DIR}/presets.cpp
  ${CMAKE_CURRENT_LIST_DIR}/specular_mips.cpp
  ${CMAKE_CURRENT_LIST_DIR}/tissue_texture.cpp
  ${CMAKE_CURRENT_LIST_DIR}/appearance.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map.cpp)
