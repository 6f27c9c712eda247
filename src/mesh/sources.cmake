# Mesh module: import (Assimp), repair, tangent frames, UVs, glTF/PLY/OBJ
# output, the airway phantom.
find_package(assimp CONFIG REQUIRED)
target_sources(mucosa_core PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/adjacency.cpp
  ${CMAKE_CURRENT_LIST_DIR}/analysis.cpp
  ${CMAKE_CURRENT_LIST_DIR}/centerline.cpp
  ${CMAKE_CURRENT_LIST_DIR}/centerline_uv.cpp
  ${CMAKE_CURRENT_LIST_DIR}/gltf_look.cpp
  ${CMAKE_CURRENT_LIST_DIR}/gltf_write.cpp
  ${CMAKE_CURRENT_LIST_DIR}/import_checks.cpp
  ${CMAKE_CURRENT_LIST_DIR}/io.cpp
  ${CMAKE_CURRENT_LIST_DIR}/load.cpp
  ${CMAKE_CURRENT_LIST_DIR}/marching_tetrahedra.cpp
  ${CMAKE_CURRENT_LIST_DIR}/normals.cpp
  ${CMAKE_CURRENT_LIST_DIR}/obj_write.cpp
  ${CMAKE_CURRENT_LIST_DIR}/phantom.cpp
  ${CMAKE_CURRENT_LIST_DIR}/primitives.cpp
  ${CMAKE_CURRENT_LIST_DIR}/ply_write.cpp
  ${CMAKE_CURRENT_LIST_DIR}/repair.cpp
  ${CMAKE_CURRENT_LIST_DIR}/tangents.cpp
  ${CMAKE_CURRENT_LIST_DIR}/uv_stretch.cpp)
target_link_libraries(mucosa_core PRIVATE assimp::assimp)
