#pragma once
// shaders/common_shading.glsl compiled as C++ with glm: the shading model's
// C++ reference IS the GLSL source. Everything lands in an anonymous namespace
// (internal linkage), so any translation unit may include this header.
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
    m.lightRange = p[Param::LightRange];
    return m;
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
    o.normalSign = f.normalSign;
    return o;
}

}  // namespace
}  // namespace mucosa::shading::glsl
