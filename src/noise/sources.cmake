target_sources(mucosa_core PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/perlin.cpp
  ${CMAKE_CURRENT_LIST_DIR}/fractal.cpp
  ${CMAKE_CURRENT_LIST_DIR}/fill.cpp)
