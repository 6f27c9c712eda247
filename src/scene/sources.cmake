# scene: scene files (parsing, defaults) and asset loading (mesh, maps,
# textures, centerline, camera path). No GL: the renderer and the fit read
# scenes through this module.
target_sources(mucosa_scene PRIVATE ${CMAKE_CURRENT_LIST_DIR}/scene.cpp ${CMAKE_CURRENT_LIST_DIR}/gltf_export.cpp)
