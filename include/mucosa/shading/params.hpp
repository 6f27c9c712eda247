#pragma once
// The one parameter registry (STYLE.md, "One parameter registry"): every
// material, BRDF and light parameter of the shading model is declared once,
// with its name, default, range, unit, description and whether the fit can
// estimate it. Scene parsing, CLI help, the viewer's sliders and the fit
// vectors all read this table. See docs/theory.md, "Shading model".
#include <array>
#include <cstddef>
#include <span>
#include <string>
#include <string_view>

namespace mucosa::shading {

// Shading modes, selectable at run time. The values are the kMode*
// constants of shaders/common_shading.glsl (checked at compile time).
enum class Mode : int {
    Noise = 0,         // the paper's method
    VertexPhong = 1,   // baseline 1
    Multitexture = 2,  // baseline 2
    Diffuse = 3,       // no specular (Category 3)
    Normals = 4,       // debug views
    Tangents = 5,
    Uv = 6,
    Depth = 7,
    Brdf = 8,                  // patient-specific texture x fitted rho, delta (Category 3)
    BrdfNoise = 9,             // Brdf plus the method's specular (Category 4)
    Procedural = 10,           // the method with run-time noise instead of the map (no texture)
    ProceduralNormals = 11,    // debug view of Procedural's perturbed normal
    Clearcoat = 12,            // glTF's KHR_materials_clearcoat: GGX coat (normal from the map) over the glTF base
    ClearcoatProcedural = 13,  // Clearcoat with the coat's normal from the run-time noise (as Procedural's)
};
inline constexpr int kModeCount = 14;

// When a mode needs texture coordinates and tangents on the mesh.
enum class UvNeed {
    Never,
    Always,
    InTextureSpace,  // only with the noise in texture space (NoiseSpace::Uv)
};

// The mode table: everything the renderer, the reference, scenes, the CLI and
// the viewer need to know about a mode, in one row. What a mode samples is
// also asked in GLSL (modeReads* in common_shading.glsl, the same predicates
// the fragment shader and the C++ reference use); a static_assert in
// src/shading/params.cpp checks the two tables row by row.
struct ModeInfo {
    Mode id;
    std::string_view name;  // --mode and scene "mode" value
    std::string_view description;
    UvNeed uvs;
    bool readsDiffuse;    // samples the subject texture
    bool readsMap;        // samples the reflectance map (so a scene must load or generate one)
    bool readsHighlight;  // samples the sphere-mapped highlight texture
    bool procedural;      // evaluates the noise per pixel (procedural_noise.glsl)
    bool headlight;       // lights per pixel and has a variant for a light exactly at the eye (Lt = Vt)
    // Renders linear radiance that goes through the endoscope's camera
    // (shaders/camera.glsl: exposure, sensor, tone curve, mask). The debug
    // views and the fitted modes (whose texture and rho, delta already are a
    // camera's output) write their values as they are.
    bool photographic;
};

// The table, in Mode order.
std::span<const ModeInfo> modes() noexcept;
const ModeInfo& info(Mode m) noexcept;
std::string_view modeName(Mode m) noexcept;  // info(m).name: "noise", "vertex-phong", ...
std::string_view modeDescription(Mode m) noexcept;
// Throws InputError(field, file, ...) listing the known names.
Mode parseMode(std::string_view name, const std::string& field = "mode", const std::string& file = "");
std::string modeList();  // "noise, vertex-phong, ..."

enum class Param : int {
    BaseColor,
    MucusColor,
    MucusOpacity,
    SpecularStrength,
    Shininess,
    BumpScale,
    MapTiling,
    Ambient,
    C0,
    C1,
    C2,
    C3,
    D1,
    D2,
    D3,
    DepthMin,
    DepthMax,
    LightIntensity,
    LightSourceRadius,
    NoiseScale,
    LightSpread,
    Wrap,
    SheenStrength,
    SheenShininess,
    MucusIor,
    ExposureEv,
    AutoExposure,
    AutoKey,
    Adaptation,
    FrameRate,
    Vignetting,
    Mask,
    MaskRadius,
    Softness,
    FullWell,
    ReadNoise,
    ToneCurve,
    AutoPeak,
    Saturation,
    NoiseSeed,
    Clearcoat,           // KHR_materials_clearcoat clearcoatFactor (the clearcoat mode)
    ClearcoatRoughness,  // clearcoatRoughnessFactor
    Knee,                // the video processor's highlight knee (camera.knee)
    Flare,               // the optics' veiling glare (camera.flare)
    Scatter,             // sub-surface scattering distance per channel (material.scatter, mm)
    ScatterShare,        // the share of the body light that diffuses (material.scatter_share)
};
inline constexpr std::size_t kParamCount = 46;

struct ParamInfo {
    Param id;
    std::string_view name;          // scene-file key and viewer label, snake_case
    std::string_view group;         // scene-file object: "material", "brdf", "light" or "camera"
    int components;                 // 1 (scalar) or 3 (RGB colour)
    std::array<float, 3> defaults;  // scalars use [0]
    float min, max;                 // inclusive range of every component
    std::string_view unit;          // "", "mm", "1/uv", ...; "choice": an integer naming an option
    std::string_view description;
    bool fittable;  // estimated by the BRDF fit (paper eq. 8-11)
};

// The registry, in Param order.
std::span<const ParamInfo> registry() noexcept;
const ParamInfo& info(Param p) noexcept;
// nullptr if unknown.
const ParamInfo* findParam(std::string_view name) noexcept;

// Values of every registered parameter. Starts at the defaults.
class ParamSet {
public:
    ParamSet();
    float operator[](Param p) const noexcept { return values_[static_cast<std::size_t>(p)][0]; }
    const std::array<float, 3>& color(Param p) const noexcept { return values_[static_cast<std::size_t>(p)]; }
    // Throws InputError(field, file, why) if out of range or not finite;
    // `field` defaults to "<group>.<name>".
    void set(Param p, float v, const std::string& file = "", const std::string& field = "");
    void setColor(Param p, const std::array<float, 3>& rgb, const std::string& file = "",
                  const std::string& field = "");
    // For the viewer's sliders: direct access, caller keeps values in range.
    float* data(Param p) noexcept { return values_[static_cast<std::size_t>(p)].data(); }
    bool operator==(const ParamSet&) const = default;

private:
    std::array<std::array<float, 3>, kParamCount> values_{};
};

// One line per parameter for --help: "name (unit, min..max, default d): description".
std::string registryHelp();

}  // namespace mucosa::shading
