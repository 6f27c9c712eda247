#pragma once
// A scene's look as a glTF 2.0 material (docs/engines.md): the subject
// texture, the reflectance map on a KHR_materials_clearcoat coat, and the
// registry's numbers (shading::gltfMaterialValues). `mucosa export`,
// `mucosa mesh --material mucosa` and `mucosa phantom` write it.
#include <mucosa/mesh/gltf.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/scene/scene.hpp>

namespace mucosa::scene {

// Whether engines should draw both sides of `mesh` (glTF doubleSided): true
// unless it is watertight (no boundary or non-manifold edge) and its
// normals face out of the volume it encloses, the only case in which no
// camera can see a back face. An airway (open ends, or normals facing the
// lumen for a camera inside it) is double-sided.
bool gltfDoubleSided(const mesh::Mesh& mesh);

// The material "mucosa" (one material; Mesh::materials should be empty or
// all 0) with its images and textures:
//  - baseColorTexture: assets.diffuse with the renderer's albedo baked in
//    (shading::mucusAlbedo per texel, sRGB-encoded PNG); in the fitted modes
//    (brdf, brdf-noise), which read the atlas as it is, the atlas's own PNG
//    bytes; its KHR_texture_transform from scene.diffuseUvTransform (a fit's
//    uv_min..uv_max) when that is not the identity. Without a diffuse
//    texture, baseColorFactor = the albedo.
//  - KHR_materials_clearcoat: clearcoatFactor, clearcoatRoughnessFactor and
//    clearcoatNormalTexture = the reflectance map (the scene's map file's
//    bytes, or the generated map as PNG), scale = bump_scale,
//    KHR_texture_transform = map_tiling. Without a map, the coat is flat.
//  - KHR_materials_ior, KHR_materials_specular: the film's sheen.
mesh::GltfLook gltfLook(const Scene& scene, const SceneAssets& assets, bool doubleSided);

// The untextured look (`--material plain`): baseColorFactor = the registry's
// albedo (shading::GltfMaterialValues::albedoNoTexture), the sheen's
// roughness, nothing else.
mesh::GltfLook plainGltfLook(const shading::ParamSet& params, bool doubleSided);

}  // namespace mucosa::scene
