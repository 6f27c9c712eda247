#include <mucosa/shading/gltf_material.hpp>

#include <algorithm>
#include <cmath>

namespace mucosa::shading {

namespace {

float srgbToLinear(float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

}  // namespace

float gltfRoughnessFromPhong(float shininess) {
    const double alpha = std::sqrt(2.0 / (4.0 * double(shininess) + 2.0));
    return static_cast<float>(std::sqrt(alpha));
}

GltfMaterialValues gltfMaterialValues(const ParamSet& p) {
    GltfMaterialValues v{};
    const auto& base = p.color(Param::BaseColor);
    const auto& mucus = p.color(Param::MucusColor);
    const float o = p[Param::MucusOpacity];
    for (int k = 0; k < 3; ++k) v.albedoNoTexture[k] = base[k] * (1 - o) + mucus[k] * o;
    v.metallic = 0;
    v.roughness = gltfRoughnessFromPhong(p[Param::SheenShininess]);
    v.ior = p[Param::MucusIor];
    v.specularFactor = p[Param::SheenStrength];
    v.clearcoatRoughness = gltfRoughnessFromPhong(p[Param::Shininess]);
    const double alpha = double(v.clearcoatRoughness) * v.clearcoatRoughness;
    const double factor = double(p[Param::SpecularStrength]) * 4.0 * alpha * alpha / kGltfClearcoatF0;
    v.clearcoatClamped = factor > 1.0;
    v.clearcoatFactor = static_cast<float>(std::min(factor, 1.0));
    v.clearcoatNormalScale = p[Param::BumpScale];
    v.mapTiling = p[Param::MapTiling];
    return v;
}

std::array<float, 3> mucusAlbedo(const std::array<float, 3>& srgb, const ParamSet& p) {
    const auto& base = p.color(Param::BaseColor);
    const auto& mucus = p.color(Param::MucusColor);
    const float o = p[Param::MucusOpacity];
    std::array<float, 3> a;
    for (int k = 0; k < 3; ++k) a[k] = srgbToLinear(srgb[k]) * base[k] * (1 - o) + mucus[k] * o;
    return a;
}

GltfTextureTransform gltfTextureTransform(const std::array<float, 4>& glUv, bool repeat) {
    GltfTextureTransform t;
    t.scale = {glUv[0], glUv[1]};
    double ou = glUv[2], ov = 1.0 - double(glUv[1]) - double(glUv[3]);
    if (repeat) {
        ou -= std::floor(ou);
        ov -= std::floor(ov);
    }
    t.offset = {static_cast<float>(ou), static_cast<float>(ov)};
    return t;
}

}  // namespace mucosa::shading
