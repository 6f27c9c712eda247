# Synthetic endoscopy datasets: per-frame ground truth (ground_truth.cpp) and
# the ray caster it sees through lenses with (raycast.cpp), the exporters to
# other tools' formats (export.cpp), the endoscope lens models (lens.cpp) and
# which side of a surface a camera in the lumen sees (orient.cpp).
# Its own layer on mucosa::core: it reads and writes frames files (frames)
# and takes a pinhole's depth pass from the z-buffer (raster); the GL frames
# it pairs with are rendered by the caller (mucosa render).
target_sources(mucosa_dataset PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/ground_truth.cpp
  ${CMAKE_CURRENT_LIST_DIR}/raycast.cpp
  ${CMAKE_CURRENT_LIST_DIR}/export.cpp
  ${CMAKE_CURRENT_LIST_DIR}/lens.cpp
  ${CMAKE_CURRENT_LIST_DIR}/orient.cpp)
# The shading maths compiled as C++ (src/shading/glsl.hpp) is glm: build-time only.
target_link_libraries(mucosa_dataset PRIVATE $<BUILD_INTERFACE:glm::glm>)
