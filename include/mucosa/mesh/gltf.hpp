#pragma once
// What a glTF 2.0 file carries besides its geometry: materials, textures,
// samplers and images (docs/engines.md). Read straight from the file's JSON
// and binary chunk (Assimp, which reads the geometry, drops extensions), so a
// model re-exported by `mucosa mesh in.glb -o out.glb` keeps its look; and
// the same structure carries Mucosa's own material (shading/gltf_material.hpp)
// into mesh::writeGltf.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mucosa::mesh {

// Mesh::materials value of a triangle that has no material.
inline constexpr std::uint32_t kNoMaterial = 0xFFFFFFFFu;

struct GltfLook {
    // glTF arrays as in a file: materials reference textures by index,
    // textures images and samplers. An image's "uri" and "bufferView" are
    // absent: its payload is imageData[i], and the writer places it (a
    // bufferView in .glb, a data URI in .gltf) with its "mimeType".
    nlohmann::json materials = nlohmann::json::array();
    nlohmann::json textures = nlohmann::json::array();
    nlohmann::json samplers = nlohmann::json::array();
    nlohmann::json images = nlohmann::json::array();
    std::vector<std::vector<std::uint8_t>> imageData;
    // Of the extensions these objects use, the ones the source file required
    // (the writer declares extensionsUsed itself, from what it writes).
    std::vector<std::string> extensionsRequired;
};

// Reads the look of a .gltf or .glb: every material, texture, sampler and
// image, and each image's bytes (from the binary chunk, a buffer, a data URI,
// or a file beside the model: never outside its folder). Throws IoError
// (unreadable) or InputError naming the file (not glTF 2.0, malformed JSON,
// an index or byte range out of bounds, an image it cannot find).
GltfLook readGltfLook(const std::filesystem::path& path);

// Keeps the materials marked `used` and the textures, images and samplers
// they reach (a texture is reached through any "<name>Texture" object with an
// "index" inside a material, the glTF and KHR_materials_* naming; an image
// through a texture's "source" or an extension's "source"), renumbering the
// references. Returns each old material's new index (kNoMaterial: dropped).
// When everything is used nothing changes, byte for byte.
std::vector<std::uint32_t> pruneGltfLook(GltfLook& look, const std::vector<bool>& materialUsed);

// The highest TEXCOORD_n a material of `look` reads ("texCoord" of its
// texture references, KHR_texture_transform's included); -1 if it reads no
// texture.
int maxTexCoord(const GltfLook& look);

// Whether a material reads any texture (a "<name>Texture" object anywhere in it).
bool readsTexture(const nlohmann::json& material);

// Every extension name used inside `json` (keys of any "extensions" object).
void collectExtensions(const nlohmann::json& json, std::vector<std::string>& names);

}  // namespace mucosa::mesh
