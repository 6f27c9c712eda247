#pragma once
// shaders/procedural_noise.glsl and shaders/common_shading.glsl compiled as
// C++ with glm: the shading model's C++ reference IS the GLSL source. Everything lands in an anonymous namespace
// (internal linkage), so any translation unit may include this header.
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

#include <mucosa/shading/params.hpp>
#include <mucosa/shading/reference.hpp>

namespace mucosa::shading::glsl {
namespace {

using namespace glm;

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wunused-variable"
#endif
// The permutation procedural_noise.glsl reads through permAt, permPairAt and
// permSlicePairAt (in GLSL uniform arrays): set for the current thread by PermutationScope.
inline thread_local const std::uint8_t* tPermutation = nullptr;
inline int permAt(int i) {
    return tPermutation[i & 255];
}
inline int permPairAt(int i) {
    return tPermutation[i & 255] | tPermutation[(i + 1) & 255] << 8;
}
// In GLSL a table made for the frame's slice (render::permutationUniforms).
inline int permSlicePairAt(int j, int Z0) {
    return permPairAt(permAt(j) + Z0);
}
// The mode predicates are constant expressions in C++ (checked against the
// mode table at compile time, src/shading/params.cpp).
#define MUCOSA_CONSTEXPR constexpr
// procedural_noise.glsl and camera.glsl first: common_shading.glsl uses
// their Procedural struct and sRGB decoding.
#include "../../shaders/camera.glsl"
#include "../../shaders/procedural_noise.glsl"
#include "../../shaders/scatter.glsl"
// (A separate block, so include sorting keeps the order.)
#include "../../shaders/common_shading.glsl"
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

// The registry's values in the layout of the GLSL Material struct.
inline Material packMaterial(const ParamSet& p) {
    Material m;
    const auto& base = p.color(Param::BaseColor);
    const auto& mucus = p.color(Param::MucusColor);
    m.baseColor = vec3(base[0], base[1], base[2]);
    m.mucusColor = vec3(mucus[0], mucus[1], mucus[2]);
    m.mucusOpacity = p[Param::MucusOpacity];
    m.specularStrength = p[Param::SpecularStrength];
    m.shininess = p[Param::Shininess];
    m.bumpScale = p[Param::BumpScale];
    m.mapTiling = p[Param::MapTiling];
    m.ambient = p[Param::Ambient];
    m.c = vec4(p[Param::C0], p[Param::C1], p[Param::C2], p[Param::C3]);
    m.d = vec3(p[Param::D1], p[Param::D2], p[Param::D3]);
    m.depthMin = p[Param::DepthMin];
    m.depthMax = p[Param::DepthMax];
    m.lightIntensity = p[Param::LightIntensity];
    m.lampSourceRadius = p[Param::LightSourceRadius];
    m.lampSpread = p[Param::LightSpread];
    m.wrap = p[Param::Wrap];
    m.sheenStrength = p[Param::SheenStrength];
    m.sheenShininess = p[Param::SheenShininess];
    const float n = p[Param::MucusIor];
    m.mucusF0 = ((n - 1.0f) / (n + 1.0f)) * ((n - 1.0f) / (n + 1.0f));
    m.clearcoat = p[Param::Clearcoat];
    m.clearcoatRoughness = p[Param::ClearcoatRoughness];
    // The glTF base's specular is the film's sheen lobe in glTF terms (its
    // roughness from the Phong exponent n by the lobe match Phong n ~
    // Blinn-Phong 4n ~ GGX alpha^2 = 2 / (4n + 2); docs/rendering.md).
    m.baseRoughness = std::sqrt(std::sqrt(2.0f / (4.0f * p[Param::SheenShininess] + 2.0f)));
    return m;
}

// The registry's camera values and the frame's size and projection in the
// layout of the GLSL Camera struct (camera.glsl). `exposure` is the linear
// factor the frame uses (2^EV, after auto-exposure: shading::ExposureState);
// `veil` the veiling glare's radiance (shading::veilingGlare).
inline Camera packCamera(const FrameSetup& f, float exposure, glm::vec3 veil = glm::vec3(0.0f)) {
    const ParamSet& p = f.params;
    Camera c;
    c.exposure = exposure;
    c.vignettingPower = p[Param::Vignetting];
    // The projection's focal terms: P[0][0] = 1 / tan(fov_x / 2), P[1][1] = 1 / tan(fov_y / 2).
    c.tanHalfFovX = f.projection[0] != 0.0f ? 1.0f / f.projection[0] : 1.0f;
    c.tanHalfFovY = f.projection[5] != 0.0f ? 1.0f / f.projection[5] : 1.0f;
    c.width = static_cast<float>(f.width);
    c.height = static_cast<float>(f.height);
    c.mask = static_cast<int>(p[Param::Mask]);
    c.maskRadius = p[Param::MaskRadius];
    c.softness = p[Param::Softness];
    c.fullWell = p[Param::FullWell];
    c.readNoise = p[Param::ReadNoise];
    c.toneCurve = static_cast<int>(p[Param::ToneCurve]);
    // Seed 0 is the frame index itself; another seed scatters it (Weyl's
    // golden-ratio constant), so each (seed, frame) has its own pattern.
    c.frameSeed = static_cast<int>(static_cast<std::uint32_t>(f.frameIndex) ^
                                   (static_cast<std::uint32_t>(p[Param::NoiseSeed]) * 0x9E3779B1u));
    c.saturation = p[Param::Saturation];
    c.knee = p[Param::Knee];
    c.veil = veil;
    return c;
}

// Binds a permutation table (noise::Permutation::table()) for permAt on this
// thread while in scope.
class PermutationScope {
public:
    explicit PermutationScope(const std::uint8_t* table) : previous_(tPermutation) { tPermutation = table; }
    ~PermutationScope() { tPermutation = previous_; }
    PermutationScope(const PermutationScope&) = delete;
    PermutationScope& operator=(const PermutationScope&) = delete;

private:
    const std::uint8_t* previous_;
};

// The frame's procedural settings in the layout of the GLSL Procedural struct.
inline Procedural packProcedural(const FrameSetup& f) {
    const noise::FractalParams& n = f.procedural.noise;
    Procedural p;
    p.frequency = static_cast<float>(n.frequency);
    p.octaves = n.octaves;
    p.lacunarity = static_cast<float>(n.lacunarity);
    p.gain = static_cast<float>(n.gain);
    p.z = static_cast<float>(n.z);
    p.turbulence = n.turbulence ? 1 : 0;
    p.tileable = n.tileable ? 1 : 0;
    p.strength = f.procedural.strength;
    p.space = f.procedural.space == NoiseSpace::Object ? kSpaceObject : kSpaceUv;
    p.scaleMm = f.params[Param::NoiseScale];
    p.antialias = f.specularAA ? 1 : 0;
    p.texels = static_cast<float>(f.procedural.texels);
    return p;
}

inline mat4 toMat4(const Mat4& a) {
    mat4 r;
    for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) r[c][row] = a[static_cast<std::size_t>(c * 4 + row)];
    return r;
}

inline Frame packFrame(const FrameSetup& f) {
    Frame o;
    o.view = toMat4(f.view);
    o.viewProj = toMat4(f.projection) * o.view;
    o.eye = vec3(f.eye[0], f.eye[1], f.eye[2]);
    o.light = vec3(f.light[0], f.light[1], f.light[2]);
    // The camera looks down its -z: the view matrix's third row, negated.
    const vec3 axis = -vec3(o.view[0][2], o.view[1][2], o.view[2][2]);
    o.lampAxis = length(axis) > kTiny ? normalize(axis) : vec3(0.0f, 0.0f, -1.0f);
    o.normalSign = f.normalSign;
    o.specularAA = f.specularAA ? 1 : 0;
    o.diffuseUvTransform =
        vec4(f.diffuseUvTransform[0], f.diffuseUvTransform[1], f.diffuseUvTransform[2], f.diffuseUvTransform[3]);
    return o;
}

}  // namespace
}  // namespace mucosa::shading::glsl
