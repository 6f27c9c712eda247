#include <mucosa/shading/params.hpp>

#include <cmath>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>

#include "shading/glsl.hpp"

namespace mucosa::shading {

namespace {

using U = UvNeed;
// name, description, uvs, reads diffuse / map / highlight, procedural, headlight, photographic
constexpr std::array<ModeInfo, kModeCount> kModes = {{
    {Mode::Noise, "noise", "the paper's method: per-pixel specular from the reflectance map over the diffuse texture",
     U::Always, true, true, false, false, true, true},
    {Mode::VertexPhong, "vertex-phong", "baseline 1: per-vertex Phong lighting, Gouraud-interpolated", U::Never, true,
     false, false, false, false, true},
    {Mode::Multitexture, "multitexture",
     "baseline 2: per-vertex lighting x texture plus a sphere-mapped highlight texture (fixed-function look)", U::Never,
     true, false, true, false, false, true},
    {Mode::Diffuse, "diffuse", "no specular (the paper's Category 3)", U::Never, true, false, false, false, false,
     true},
    {Mode::Normals, "normals", "debug: the map's perturbed normal in world space as 0.5 N + 0.5", U::Always, false,
     true, false, false, false, false},
    {Mode::Tangents, "tangents", "debug: tangent T in world space as 0.5 T + 0.5", U::Always, false, false, false,
     false, false, false},
    {Mode::Uv, "uv", "debug: fract(u), fract(v) in red, green", U::Always, false, false, false, false, false, false},
    {Mode::Depth, "depth", "debug: 1 - r, the depth ratio of eq. 10", U::Never, false, false, false, false, false,
     false},
    {Mode::Brdf, "brdf",
     "patient-specific: texture x rho(gamma) delta(r) from mucosa fit, no ambient, tint or fall-off (Category 3)",
     U::Always, true, false, false, false, false, false},
    {Mode::BrdfNoise, "brdf-noise", "patient-specific plus the method's noise-based specular (Category 4)", U::Always,
     true, true, false, false, true, false},
    {Mode::Procedural, "procedural",
     "the method with run-time noise: the map's fractal sum evaluated per pixel in texture or object space, no map",
     U::InTextureSpace, true, false, false, true, true, true},
    {Mode::ProceduralNormals, "procedural-normals",
     "debug: the procedural mode's perturbed normal in world space as 0.5 N + 0.5 (texture or object space)",
     U::InTextureSpace, false, false, false, true, false, false},
    {Mode::Clearcoat, "clearcoat",
     "glTF's clear coat (KHR_materials_clearcoat): a GGX coat on the reflectance map's normal over the glTF "
     "metallic-roughness base on the geometric normal, per pixel",
     U::Always, true, true, false, false, true, true},
    {Mode::ClearcoatProcedural, "clearcoat-procedural",
     "the clearcoat mode with the coat's normal from the run-time noise (the procedural mode's, texture or object "
     "space), no map",
     U::InTextureSpace, true, false, false, true, true, true},
}};

// The C++ table and the GLSL agree: the same values, in Mode order, and the
// same answers from the predicates the shader and the reference use.
static_assert(glsl::kModeCount == kModeCount);
static_assert(glsl::kModeNoise == static_cast<int>(Mode::Noise));
static_assert(glsl::kModeVertexPhong == static_cast<int>(Mode::VertexPhong));
static_assert(glsl::kModeMultitexture == static_cast<int>(Mode::Multitexture));
static_assert(glsl::kModeDiffuse == static_cast<int>(Mode::Diffuse));
static_assert(glsl::kModeNormals == static_cast<int>(Mode::Normals));
static_assert(glsl::kModeTangents == static_cast<int>(Mode::Tangents));
static_assert(glsl::kModeUv == static_cast<int>(Mode::Uv));
static_assert(glsl::kModeDepth == static_cast<int>(Mode::Depth));
static_assert(glsl::kModeBrdf == static_cast<int>(Mode::Brdf));
static_assert(glsl::kModeBrdfNoise == static_cast<int>(Mode::BrdfNoise));
static_assert(glsl::kModeProcedural == static_cast<int>(Mode::Procedural));
static_assert(glsl::kModeProceduralNormals == static_cast<int>(Mode::ProceduralNormals));
static_assert(glsl::kModeClearcoat == static_cast<int>(Mode::Clearcoat));
static_assert(glsl::kModeClearcoatProcedural == static_cast<int>(Mode::ClearcoatProcedural));
constexpr bool tablesAgree() {
    for (std::size_t i = 0; i < kModes.size(); ++i) {
        const ModeInfo& m = kModes[i];
        const int k = static_cast<int>(m.id);
        if (k != static_cast<int>(i) || glsl::modeReadsDiffuse(k) != m.readsDiffuse ||
            glsl::modeReadsReflectanceMap(k) != m.readsMap || glsl::modeReadsHighlight(k) != m.readsHighlight ||
            glsl::modeIsProcedural(k) != m.procedural || glsl::modeIsPhotographic(k) != m.photographic)
            return false;
    }
    return true;
}
static_assert(tablesAgree(), "shading::ModeInfo disagrees with the modeReads* predicates of common_shading.glsl");

using P = Param;
// Defaults give a bronchoscope-like look on the phantom with the 'bronchial'
// map, measured against real frames with the realism statistics (README):
// salmon tissue under a thin, slightly milky mucous layer, few sharp glints
// that clip, the lamp's inverse-square fall-off, a video camera's response.
constexpr std::array<ParamInfo, kParamCount> kRegistry = {{
    {P::BaseColor,
     "base_color",
     "material",
     3,
     {0.75f, 0.27f, 0.12f},
     0.0f,
     1.0f,
     "",
     "Tissue albedo (linear RGB), multiplies the diffuse texture",
     false},
    {P::MucusColor,
     "mucus_color",
     "material",
     3,
     {0.95f, 0.85f, 0.78f},
     0.0f,
     1.0f,
     "",
     "Colour of the mucous layer (RGB)",
     false},
    {P::MucusOpacity,
     "mucus_opacity",
     "material",
     1,
     {0.15f, 0, 0},
     0.0f,
     1.0f,
     "",
     "Opacity of the mucous layer: 0 clear, 1 hides the tissue",
     false},
    {P::SpecularStrength,
     "specular_strength",
     "material",
     1,
     {2.0f, 0, 0},
     0.0f,
     32.0f,
     "",
     "Strength k_s of the specular highlight",
     false},
    {P::Shininess,
     "shininess",
     "material",
     1,
     {120.0f, 0, 0},
     1.0f,
     2000.0f,
     "",
     "Phong exponent n of the highlight lobe (larger = tighter)",
     false},
    {P::BumpScale,
     "bump_scale",
     "material",
     1,
     {1.0f, 0, 0},
     0.0f,
     8.0f,
     "",
     "Scales the tilt of the reflectance map's normals (0 = flat, 1 = as generated)",
     false},
    {P::MapTiling,
     "map_tiling",
     "material",
     1,
     {4.0f, 0, 0},
     0.001f,
     1024.0f,
     "1/uv",
     "Repeats of the reflectance map per unit of texture coordinate",
     false},
    {P::Ambient,
     "ambient",
     "material",
     1,
     {0.03f, 0, 0},
     0.0f,
     1.0f,
     "",
     "Ambient term k_a: light scattered back by the airway's walls, as a fraction of the lamp's irradiance at 10 mm",
     false},
    {P::C0, "c0", "brdf", 1, {0.0f, 0, 0}, -10.0f, 10.0f, "", "rho(gamma) constant term (paper eq. 9)", true},
    {P::C1, "c1", "brdf", 1, {1.0f, 0, 0}, -10.0f, 10.0f, "", "rho(gamma) linear term (paper eq. 9)", true},
    {P::C2, "c2", "brdf", 1, {0.0f, 0, 0}, -10.0f, 10.0f, "", "rho(gamma) quadratic term (paper eq. 9)", true},
    {P::C3, "c3", "brdf", 1, {0.0f, 0, 0}, -10.0f, 10.0f, "", "rho(gamma) cubic term (paper eq. 9)", true},
    {P::D1, "d1", "brdf", 1, {0.0f, 0, 0}, -10.0f, 10.0f, "", "delta(r) linear term (paper eq. 10)", true},
    {P::D2, "d2", "brdf", 1, {0.0f, 0, 0}, -10.0f, 10.0f, "", "delta(r) quadratic term (paper eq. 10)", true},
    {P::D3, "d3", "brdf", 1, {0.0f, 0, 0}, -10.0f, 10.0f, "", "delta(r) cubic term (paper eq. 10)", true},
    {P::DepthMin,
     "depth_min_mm",
     "brdf",
     1,
     {0.0f, 0, 0},
     0.0f,
     10000.0f,
     "mm",
     "z_min of the depth ratio r (paper eq. 10)",
     false},
    {P::DepthMax,
     "depth_max_mm",
     "brdf",
     1,
     {100.0f, 0, 0},
     0.001f,
     10000.0f,
     "mm",
     "z_max of the depth ratio r (paper eq. 10)",
     false},
    {P::LightIntensity,
     "intensity",
     "light",
     1,
     {400.0f, 0, 0},
     0.0f,
     1000000.0f,
     "mm^2",
     "Radiant intensity I_L of the endoscope's lamp on its axis: irradiance 1 at sqrt(I_L) mm",
     false},
    {P::LightSourceRadius,
     "source_radius_mm",
     "light",
     1,
     {1.5f, 0, 0},
     0.01f,
     100.0f,
     "mm",
     "Radius a of the lamp's emitting disk: irradiance I / (d^2 + a^2) on its axis (exact for a Lambertian disk)",
     false},
    {P::NoiseScale,
     "noise_scale_mm",
     "material",
     1,
     {15.0f, 0, 0},
     0.01f,
     100000.0f,
     "mm",
     "Procedural modes in object space: mm of surface per map width (the map's frequency counts cycles per width)",
     false},
    {P::LightSpread,
     "spread",
     "light",
     1,
     {0.5f, 0, 0},
     0.0f,
     50.0f,
     "",
     "Angular fall-off mu of the lamp: exp(-mu (1 - cos theta)), theta from the scope's axis (0 = isotropic)",
     false},
    {P::Wrap,
     "wrap",
     "material",
     1,
     {0.05f, 0, 0},
     0.0f,
     1.0f,
     "",
     "Wrap lighting w, a cheap stand-in for sub-surface light (scatter is the model): the diffuse cosine "
     "becomes (cos + w) / (1 + w)",
     false},
    {P::SheenStrength,
     "sheen",
     "material",
     1,
     {0.6f, 0, 0},
     0.0f,
     1.0f,
     "",
     "Strength of the mucus film's broad sheen: an energy-normalised Phong lobe times Fresnel (0 = off)",
     false},
    {P::SheenShininess,
     "sheen_shininess",
     "material",
     1,
     {8.0f, 0, 0},
     1.0f,
     200.0f,
     "",
     "Phong exponent of the sheen lobe (small = broad)",
     false},
    {P::MucusIor,
     "mucus_ior",
     "material",
     1,
     {1.34f, 0, 0},
     1.0f,
     3.0f,
     "",
     "Refractive index of the mucus film (water: 1.33): Fresnel F0 = ((n - 1) / (n + 1))^2 of the sheen",
     false},
    {P::ExposureEv,
     "exposure_ev",
     "camera",
     1,
     {0.0f, 0, 0},
     -30.0f,
     30.0f,
     "EV",
     "Exposure in stops: the signal is radiance x 2^EV; with auto-exposure, its compensation",
     false},
    {P::AutoExposure,
     "auto_exposure",
     "camera",
     1,
     {1.0f, 0, 0},
     0.0f,
     1.0f,
     "choice",
     "Auto-exposure as video bronchoscopes do it: 1 = on (metered mean to auto_key), 0 = fixed exposure_ev",
     false},
    {P::AutoKey,
     "auto_key",
     "camera",
     1,
     {0.22f, 0, 0},
     0.001f,
     1.0f,
     "",
     "Auto-exposure's target: the metered mean sensor signal (0..1, before the tone curve)",
     false},
    {P::Adaptation,
     "adaptation_s",
     "camera",
     1,
     {0.2f, 0, 0},
     0.0f,
     60.0f,
     "s",
     "Auto-exposure's time constant: it closes 63 % of the gap in this time (0 = at once)",
     false},
    {P::FrameRate,
     "frame_rate",
     "camera",
     1,
     {30.0f, 0, 0},
     1.0f,
     1000.0f,
     "1/s",
     "Video frame rate: the time between frames of a camera path, for auto-exposure",
     false},
    {P::Vignetting,
     "vignetting",
     "camera",
     1,
     {1.5f, 0, 0},
     0.0f,
     8.0f,
     "",
     "Natural vignetting: cos^k of the field angle (4 = a thin lens's cos^4 law, 0 = off)",
     false},
    {P::Mask,
     "mask",
     "camera",
     1,
     {1.0f, 0, 0},
     0.0f,
     2.0f,
     "choice",
     "The scope's field-of-view mask: 0 = none, 1 = circle, 2 = octagon",
     false},
    {P::MaskRadius,
     "mask_radius",
     "camera",
     1,
     {1.0f, 0, 0},
     0.1f,
     2.0f,
     "",
     "Mask radius (octagon: inradius) / half the smaller side of the frame",
     false},
    {P::Softness,
     "softness_px",
     "camera",
     1,
     {1.0f, 0, 0},
     0.0f,
     1.2f,
     "px",
     "Optical softness: sigma of the Gaussian point-spread function over 5 x 5 pixels (0 = sharp)",
     false},
    {P::FullWell,
     "full_well",
     "camera",
     1,
     {50000.0f, 0, 0},
     0.0f,
     1000000.0f,
     "e-",
     "Photo-electrons at full signal: shot-noise variance signal / full_well (0 = no shot noise)",
     false},
    {P::ReadNoise,
     "read_noise",
     "camera",
     1,
     {0.0005f, 0, 0},
     0.0f,
     0.2f,
     "",
     "Read-noise deviation in units of the full signal (0 = none)",
     false},
    {P::ToneCurve,
     "tone_curve",
     "camera",
     1,
     {1.0f, 0, 0},
     0.0f,
     2.0f,
     "choice",
     "Camera response: 0 = linear, 1 = BT.709 (video), 2 = sRGB",
     false},
    {P::AutoPeak,
     "auto_peak",
     "camera",
     1,
     {0.4f, 0, 0},
     0.0f,
     1.0f,
     "",
     "Auto-exposure's metering: 0 = the mean, 1 = the peak (95th percentile), between: a mix (a scope's peak/average "
     "modes)",
     false},
    {P::Saturation,
     "saturation",
     "camera",
     1,
     {1.5f, 0, 0},
     0.0f,
     4.0f,
     "",
     "Colour enhancement of the video processor: saturation gain about the luma after the tone curve (1 = none)",
     false},
    {P::NoiseSeed,
     "noise_seed",
     "camera",
     1,
     {0.0f, 0, 0},
     0.0f,
     2047.0f,
     "",
     "The sensor noise's seed (a whole number): each frame's noise pattern is a function of (seed, frame index); "
     "another seed, another realisation of the same frames",
     false},
    // The clearcoat modes' coat (glTF's KHR_materials_clearcoat, docs/theory.md,
    // "Clear coat"). The defaults are the noise mode's highlight in glTF terms
    // (docs/rendering.md): the GGX lobe whose peak for a head-on light is the
    // Phong lobe's k_s = 2 with exponent n = 120, roughness (2 / (4n + 2))^(1/4).
    {P::Clearcoat,
     "clearcoat",
     "material",
     1,
     {0.83f, 0, 0},
     0.0f,
     1.0f,
     "",
     "Clearcoat modes: the coat's weight (glTF clearcoatFactor; 0 = no coat, the glTF base alone)",
     false},
    {P::ClearcoatRoughness,
     "clearcoat_roughness",
     "material",
     1,
     {0.254f, 0, 0},
     0.0f,
     1.0f,
     "",
     "Clearcoat modes: the coat's GGX roughness (glTF clearcoatRoughnessFactor, alpha = roughness^2; at least 0.045 "
     "for the point lamp)",
     false},
    {P::Knee,
     "knee",
     "camera",
     1,
     {0.8f, 0, 0},
     0.0f,
     1.0f,
     "",
     "The video processor's highlight knee: above this output level the response bends, smoothly compressing "
     "everything up to the sensor's saturation below white (1 = none: the sensor clips to white)",
     false},
    {P::Flare,
     "flare",
     "camera",
     1,
     {0.03f, 0, 0},
     0.0f,
     0.3f,
     "",
     "Veiling glare of the scope's optics: this share of the field's mean radiance, scattered by the lenses, "
     "lies evenly over the sensor and lifts the dark lumen (0 = none)",
     false},
    {P::Scatter,
     "scatter",
     "material",
     3,
     {0.2f, 0.1f, 0.06f},
     0.0f,
     3.0f,
     "mm",
     "Sub-surface scattering: the distance d of Burley's diffusion profile per channel (red, green, blue), how far "
     "light travels under the mucosa before it leaves it; diffused in screen space (0 = off)",
     false},
    {P::ScatterShare,
     "scatter_share",
     "material",
     1,
     {0.0f, 0, 0},
     0.0f,
     1.0f,
     "",
     "The share of the body's light that diffuses under the surface by scatter (0.5: translucent mucosa); the "
     "rest leaves the epithelium where it entered, with the texture's fine detail (0 = no scattering)",
     false},
}};

constexpr bool registryInOrder() {
    for (std::size_t i = 0; i < kRegistry.size(); ++i)
        if (static_cast<std::size_t>(kRegistry[i].id) != i) return false;
    return true;
}
static_assert(registryInOrder(), "kRegistry must list parameters in Param order");

std::string fieldName(const ParamInfo& pi, const std::string& field) {
    return field.empty() ? std::string(pi.group) + "." + std::string(pi.name) : field;
}

void checkValue(const ParamInfo& pi, float v, const std::string& file, const std::string& field) {
    if (!std::isfinite(v)) throw InputError(fieldName(pi, field), file, "must be a finite number");
    if (v < pi.min || v > pi.max)
        throw InputError(fieldName(pi, field), file, fmt::format("{} is out of range [{}, {}]", v, pi.min, pi.max));
    if (pi.unit == "choice" && v != std::floor(v))
        throw InputError(fieldName(pi, field), file,
                         fmt::format("{} is not one of the choices: {}", v, pi.description));
}

}  // namespace

std::span<const ModeInfo> modes() noexcept {
    return kModes;
}
const ModeInfo& info(Mode m) noexcept {
    return kModes[static_cast<std::size_t>(m)];
}
std::string_view modeName(Mode m) noexcept {
    return info(m).name;
}
std::string_view modeDescription(Mode m) noexcept {
    return info(m).description;
}

std::string modeList() {
    std::string s;
    for (const ModeInfo& m : kModes) s += (s.empty() ? "" : ", ") + std::string(m.name);
    return s;
}

Mode parseMode(std::string_view name, const std::string& field, const std::string& file) {
    for (const ModeInfo& m : kModes)
        if (m.name == name) return m.id;
    throw InputError(field, file, fmt::format("unknown mode '{}' (known: {})", name, modeList()));
}

std::span<const ParamInfo> registry() noexcept {
    return kRegistry;
}
const ParamInfo& info(Param p) noexcept {
    return kRegistry[static_cast<std::size_t>(p)];
}

const ParamInfo* findParam(std::string_view name) noexcept {
    for (const ParamInfo& pi : kRegistry)
        if (pi.name == name) return &pi;
    return nullptr;
}

ParamSet::ParamSet() {
    for (const ParamInfo& pi : kRegistry) values_[static_cast<std::size_t>(pi.id)] = pi.defaults;
}

void ParamSet::set(Param p, float v, const std::string& file, const std::string& field) {
    const ParamInfo& pi = info(p);
    if (pi.components != 1) throw InputError(fieldName(pi, field), file, "is a colour: give [r, g, b]");
    checkValue(pi, v, file, field);
    values_[static_cast<std::size_t>(p)] = {v, 0.0f, 0.0f};
}

void ParamSet::setColor(Param p, const std::array<float, 3>& rgb, const std::string& file, const std::string& field) {
    const ParamInfo& pi = info(p);
    if (pi.components != 3) throw InputError(fieldName(pi, field), file, "is a number, not a colour");
    for (float v : rgb) checkValue(pi, v, file, field);
    values_[static_cast<std::size_t>(p)] = rgb;
}

std::string registryHelp() {
    std::string s;
    for (const ParamInfo& pi : kRegistry) {
        const std::string def = pi.components == 3
                                    ? fmt::format("[{}, {}, {}]", pi.defaults[0], pi.defaults[1], pi.defaults[2])
                                    : fmt::format("{}", pi.defaults[0]);
        s += fmt::format("  {}.{} ({}{}..{}, default {}){}: {}\n", pi.group, pi.name,
                         pi.unit.empty() ? "" : std::string(pi.unit) + ", ", pi.min, pi.max, def,
                         pi.fittable ? ", fittable" : "", pi.description);
    }
    return s;
}

}  // namespace mucosa::shading
