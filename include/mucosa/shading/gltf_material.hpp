#pragma once
// Mucosa's material in glTF 2.0 terms (docs/engines.md): the one place the
// parameter registry is mapped to a metallic-roughness material with a
// KHR_materials_clearcoat coat. `mucosa export`, `mucosa mesh --material
// mucosa` and `mucosa phantom` write these numbers; a renderer that imitates
// an engine's clearcoat (the `clearcoat` shading mode) reads the same ones.
//
// The mapping, in Mucosa's radiance units (pi x BRDF: a Lambertian albedo a
// gives a E, as the shaders compute):
//  - the tissue under the mucus is the base layer: baseColor = the albedo the
//    renderer uses, mix(texture x base_color, mucus_color, mucus_opacity)
//    (baked into the texture when there is one), metallic 0;
//  - the mucus film's sharp, noise-shaped highlight (k_s, Phong exponent n,
//    the reflectance map) is the clearcoat: its GGX roughness from n by the
//    usual lobe match, Phong n ~ Blinn-Phong 4n (shaders: toksvigShininess)
//    and Blinn-Phong s ~ GGX alpha^2 = 2 / (s + 2), so alpha = sqrt(2 / (4n + 2))
//    and glTF's perceptual roughness = sqrt(alpha); its factor matches the
//    peak: a full coat (F0 = 0.04, the extension's fixed IOR 1.5) reflects
//    F0 / (4 alpha^2) of E at normal incidence, Mucosa's lobe k_s, so
//    clearcoatFactor = min(1, k_s 4 alpha^2 / 0.04); its normal texture is the
//    reflectance map (the paper's noise), scale = bump_scale, tiled by
//    map_tiling through KHR_texture_transform;
//  - the film's broad sheen (sheen, sheen_shininess, mucus_ior: an
//    energy-normalised Phong lobe times Fresnel) is the base layer's
//    specular: roughness from sheen_shininess by the same rule,
//    KHR_materials_ior ior = mucus_ior (F0 0.021 for 1.34), and
//    KHR_materials_specular specularFactor = sheen.
// Not carried (an engine's own lights and camera replace them): ambient,
// wrap, the lamp, the camera and the fitted rho/delta.
#include <array>

#include <mucosa/shading/params.hpp>

namespace mucosa::shading {

// F0 of the clearcoat layer: KHR_materials_clearcoat fixes its IOR at 1.5.
inline constexpr float kGltfClearcoatF0 = 0.04f;

struct GltfMaterialValues {
    std::array<float, 3> albedoNoTexture;  // linear baseColorFactor without a texture: mix(base_color, mucus_color, o)
    float metallic = 0;
    float roughness;             // base layer (the sheen lobe)
    float ior;                   // KHR_materials_ior
    float specularFactor;        // KHR_materials_specular
    float clearcoatFactor;       // KHR_materials_clearcoat
    float clearcoatRoughness;    // clearcoatRoughnessFactor
    float clearcoatNormalScale;  // clearcoatNormalTexture.scale = bump_scale
    float mapTiling;             // repeats of the map per unit of texture coordinate
    bool clearcoatClamped;       // k_s asked for more than a full coat (factor capped at 1)
};

// The mapping above, for a parameter set.
GltfMaterialValues gltfMaterialValues(const ParamSet& params);

// GGX perceptual roughness (glTF's roughness, alpha = roughness^2) of a
// Phong lobe with exponent n: sqrt(sqrt(2 / (4n + 2))).
float gltfRoughnessFromPhong(float shininess);

// The albedo the renderer uses for an sRGB-encoded texture value (0..1):
// mix(srgbToLinear(tex) x base_color, mucus_color, mucus_opacity), linear.
std::array<float, 3> mucusAlbedo(const std::array<float, 3>& srgbTexture, const ParamSet& params);

// KHR_texture_transform of a texture Mucosa samples at (u sx + ox, v sy + oy)
// in its OpenGL texture coordinates (origin bottom-left): glTF's coordinates
// are (u, 1 - v) and its image origin is the top-left, so the same texel is
// at scale (sx, sy), offset (ox, 1 - sy - oy), rotation 0. The map's tiling t
// is (t, t, 0, 0): offset (0, 1 - t), reduced mod 1 (the sampler repeats).
struct GltfTextureTransform {
    std::array<float, 2> offset{0, 0};
    std::array<float, 2> scale{1, 1};
    bool identity() const noexcept {
        return offset == std::array<float, 2>{0, 0} && scale == std::array<float, 2>{1, 1};
    }
};
// glUv = {sx, sy, ox, oy} (shading::FrameSetup::diffuseUvTransform's order);
// repeat: the sampler repeats, so offsets are reduced to [0, 1).
GltfTextureTransform gltfTextureTransform(const std::array<float, 4>& glUv, bool repeat = true);

}  // namespace mucosa::shading
