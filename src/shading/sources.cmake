# shading: the shading model's C++ reference (shaders/common_shading.glsl
# compiled as C++ with glm) and the parameter registry.
find_package(glm CONFIG REQUIRED)
target_sources(mucosa_core PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/brdf.cpp
  ${CMAKE_CURRENT_LIST_DIR}/gltf_material.cpp
  ${CMAKE_CURRENT_LIST_DIR}/params.cpp
  ${CMAKE_CURRENT_LIST_DIR}/reference.cpp
  ${CMAKE_CURRENT_LIST_DIR}/scatter.cpp)
# glm is header-only and never in a public header: build-time only.
target_link_libraries(mucosa_core PRIVATE $<BUILD_INTERFACE:glm::glm>)
