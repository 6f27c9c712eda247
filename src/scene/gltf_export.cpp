#include <mucosa/scene/gltf_export.hpp>

#include <algorithm>
#include <cmath>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/analysis.hpp>
#include <mucosa/shading/gltf_material.hpp>

namespace mucosa::scene {

namespace {

using json = nlohmann::json;

constexpr int kLinear = 9729, kLinearMipmapLinear = 9987;

std::vector<std::uint8_t> bytesOf(const std::vector<std::byte>& b) {
    return {reinterpret_cast<const std::uint8_t*>(b.data()),
            reinterpret_cast<const std::uint8_t*>(b.data()) + b.size()};
}

// sRGB encoding of a linear value, 8 bits (rounded).
std::uint8_t encodeSrgb(float v) {
    v = std::clamp(v, 0.0f, 1.0f);
    const float e = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
    return static_cast<std::uint8_t>(std::lround(e * 255.0f));
}

// The renderer's albedo per texel (shading::mucusAlbedo), sRGB again; alpha
// is dropped (the renderer reads RGB).
image::Image8 bakeAlbedo(const image::Image8& tex, const shading::ParamSet& params) {
    const int c = tex.channels();
    image::Image8 out(tex.width(), tex.height(), 3);
    // 256 x 3 table per channel would do, but the base colour mixes channels
    // only through the texel's own value: one table per channel.
    std::array<std::array<std::uint8_t, 256>, 3> lut;
    for (int v = 0; v < 256; ++v) {
        const float s = static_cast<float>(v) / 255.0f;
        const auto a = shading::mucusAlbedo({s, s, s}, params);
        for (int k = 0; k < 3; ++k) lut[k][v] = encodeSrgb(a[k]);
    }
    for (int y = 0; y < tex.height(); ++y)
        for (int x = 0; x < tex.width(); ++x)
            for (int k = 0; k < 3; ++k) {
                const std::uint8_t v = c >= 3 ? tex.at(x, y, k) : tex.at(x, y, 0);
                out.at(x, y, k) = lut[k][v];
            }
    return out;
}

// A registry value as written: rounded to 6 decimals, so a float's binary
// tail (1.34f = 1.340000033...) does not reach the file.
double num(float v) {
    return std::round(double(v) * 1e6) / 1e6;
}

json transformJson(const shading::GltfTextureTransform& t) {
    json j = json::object();
    if (t.offset != std::array<float, 2>{0, 0}) j["offset"] = json::array({num(t.offset[0]), num(t.offset[1])});
    if (t.scale != std::array<float, 2>{1, 1}) j["scale"] = json::array({num(t.scale[0]), num(t.scale[1])});
    return j;
}

}  // namespace

bool gltfDoubleSided(const mesh::Mesh& m) {
    const mesh::MeshReport r = mesh::analyze(m);
    const bool watertight = r.boundaryEdges == 0 && r.nonManifoldEdges == 0 && r.inconsistentEdges == 0;
    return !(watertight && r.signedVolume > 0);
}

mesh::GltfLook plainGltfLook(const shading::ParamSet& params, bool doubleSided) {
    const shading::GltfMaterialValues v = shading::gltfMaterialValues(params);
    mesh::GltfLook look;
    json pbr = {{"baseColorFactor",
                 json::array({num(v.albedoNoTexture[0]), num(v.albedoNoTexture[1]), num(v.albedoNoTexture[2]), 1.0})},
                {"metallicFactor", 0.0},
                {"roughnessFactor", num(v.roughness)}};
    json material = {{"name", "mucosa plain"}, {"pbrMetallicRoughness", pbr}};
    if (doubleSided) material["doubleSided"] = true;
    look.materials.push_back(material);
    return look;
}

mesh::GltfLook gltfLook(const Scene& scene, const SceneAssets& assets, bool doubleSided) {
    const shading::GltfMaterialValues v = shading::gltfMaterialValues(scene.params);
    mesh::GltfLook look;
    look.samplers.push_back({{"magFilter", kLinear}, {"minFilter", kLinearMipmapLinear}});
    json pbr = {{"metallicFactor", 0.0}, {"roughnessFactor", num(v.roughness)}};
    auto addTexture = [&](std::vector<std::uint8_t> png, const std::string& name) {
        look.images.push_back({{"name", name}, {"mimeType", "image/png"}});
        look.imageData.push_back(std::move(png));
        look.textures.push_back({{"sampler", 0}, {"source", look.images.size() - 1}, {"name", name}});
        return look.textures.size() - 1;
    };
    if (!assets.diffuse.empty()) {
        const bool fitted = scene.mode == shading::Mode::Brdf || scene.mode == shading::Mode::BrdfNoise;
        std::vector<std::uint8_t> png;
        if (fitted && scene.diffuse)
            png = bytesOf(readFile(*scene.diffuse));
        else
            png = bytesOf(image::encodePng(fitted ? assets.diffuse : bakeAlbedo(assets.diffuse, scene.params)));
        json info = {{"index", addTexture(std::move(png), "subject texture")}};
        const shading::GltfTextureTransform t = shading::gltfTextureTransform(scene.diffuseUvTransform);
        if (!t.identity()) info["extensions"] = {{"KHR_texture_transform", transformJson(t)}};
        pbr["baseColorTexture"] = info;
    } else {
        pbr["baseColorFactor"] =
            json::array({num(v.albedoNoTexture[0]), num(v.albedoNoTexture[1]), num(v.albedoNoTexture[2]), 1.0});
    }
    json coat = {{"clearcoatFactor", num(v.clearcoatFactor)}, {"clearcoatRoughnessFactor", num(v.clearcoatRoughness)}};
    if (!assets.reflectanceMap.empty()) {
        std::vector<std::uint8_t> png = scene.reflectanceMap ? bytesOf(readFile(*scene.reflectanceMap))
                                                             : bytesOf(image::encodePng(assets.reflectanceMap));
        json info = {{"index", addTexture(std::move(png), "reflectance map")}};
        if (v.clearcoatNormalScale != 1.0f) info["scale"] = num(v.clearcoatNormalScale);
        const shading::GltfTextureTransform t = shading::gltfTextureTransform({v.mapTiling, v.mapTiling, 0.0f, 0.0f});
        if (!t.identity()) info["extensions"] = {{"KHR_texture_transform", transformJson(t)}};
        coat["clearcoatNormalTexture"] = info;
    }
    json material = {{"name", "mucosa"},
                     {"pbrMetallicRoughness", pbr},
                     {"extensions",
                      {{"KHR_materials_clearcoat", coat},
                       {"KHR_materials_ior", {{"ior", num(v.ior)}}},
                       {"KHR_materials_specular", {{"specularFactor", num(v.specularFactor)}}}}}};
    if (doubleSided) material["doubleSided"] = true;
    look.materials.push_back(material);
    if (look.textures.empty()) look.samplers = json::array();
    return look;
}

}  // namespace mucosa::scene
