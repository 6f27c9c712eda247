target_sources(mucosa PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/perlin.cpp
  ${CMAKE_CURRENT_LIST_DIR}/fractal.cpp
  ${CMAKE_CURRENT_LIST_DIR}/fill.cpp)
