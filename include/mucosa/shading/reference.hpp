#pragma once
// The C++ reference of the shading model: the same functions as the GLSL
// (both are shaders/common_shading.glsl), driven by a small software
// rasteriser that follows OpenGL's rules (pixel centres, perspective-correct
// interpolation, clipping to the near and far planes, depth test LESS). The
// parity test compares it with the GPU path pixel by pixel.
#include <array>

#include <mucosa/image/image.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/noise/fractal.hpp>
#include <mucosa/shading/params.hpp>

namespace mucosa::shading {

// 4x4 matrix, column-major (OpenGL's layout): m[col * 4 + row].
using Mat4 = std::array<float, 16>;

// Where the procedural mode evaluates its noise.
enum class NoiseSpace {
    Uv,      // texture space: the map's fractal sum at the map's coordinates (needs UVs and tangents)
    Object,  // solid noise at the surface point: no UVs or tangents needed
};

// The procedural mode's noise: the reflectance map's parameters (the scene's
// map, reflectance::MapParams), so switching between the map and the
// procedural path needs no retuning. Object space also reads the registry's
// noise_scale_mm (mm of surface per map width).
struct ProceduralSetup {
    noise::FractalParams noise;  // frequency, octaves, lacunarity, gain, seed, z, turbulence, tileable
    float strength = 0.01f;      // slope scale, as reflectance::MapParams::strength
    NoiseSpace space = NoiseSpace::Uv;
    // The detail of a map this many texels wide (the map's size): each
    // octave's slope passes through the map's central-difference response,
    // so both paths have the same slope spectrum and look alike. 0: the
    // unlimited analytic surface.
    int texels = 0;
};

// Everything a frame needs besides the mesh and the textures; the GL renderer
// (render::Renderer::draw) takes the same struct.
struct FrameSetup {
    Mat4 view{};                   // world -> eye (rigid)
    Mat4 projection{};             // eye -> clip
    std::array<float, 3> eye{};    // camera position, world mm
    std::array<float, 3> light{};  // point light position, world mm
    // +1: lit side = the side the normals face; -1: the other side (a mesh
    // whose normals point out of the airway, seen from inside).
    float normalSign = 1.0f;
    // The mesh is closed and wound counter-clockwise seen from the lit side:
    // the GL renderer may cull faces turned away (no pixel changes). The
    // reference never culls.
    bool cullBackFaces = false;
    Mode mode = Mode::Noise;
    ParamSet params;
    ProceduralSetup procedural;
    // Specular anti-aliasing: the map path samples the mip chain and widens
    // the lobe by its slope variance (Toksvig); the procedural path fades
    // octaves out at the pixel footprint. Off: the full-resolution map and
    // every octave (the paper's look, which sparkles in the distance).
    bool specularAA = true;
    // The subject texture is sampled at uv * (x, y) + (z, w): the identity, or
    // a fitted atlas spanning uv_min..uv_max mapped to [0, 1] (scene key "fit").
    std::array<float, 4> diffuseUvTransform{1, 1, 0, 0};
    int width = 640, height = 480;
    // The frame's number along its camera path: the sensor noise's pattern,
    // and frame 0 starts auto-exposure afresh (ExposureState).
    int frameIndex = 0;
    // This frame starts auto-exposure afresh, as frame 0 does: where a run
    // starts partway along a path (a dataset shard's warm-up).
    bool restartExposure = false;
    // > 0: develop with this linear exposure factor instead of metering; the
    // auto-exposure state is neither used nor changed (a second development
    // of a frame already rendered: its linear signal, its highlights).
    float fixedExposure = 0.0f;
};

// Auto-exposure (docs/theory.md, "The endoscope's camera"), as video
// bronchoscopes do it: meter the frame, aim the exposure at camera.auto_key,
// and move there with the time constant camera.adaptation_s at
// camera.frame_rate. The state a camera path carries from frame to frame.
struct ExposureState {
    bool primed = false;  // false: the next frame takes its target at once
    float ev = 0.0f;      // log2 of the exposure factor
};

// The meter reads the frame's linear radiance at a kMeterGrid x kMeterGrid
// grid of pixels: (floor((i + 0.5) W / kMeterGrid), floor((j + 0.5) H /
// kMeterGrid)), bottom-up (what a nearest-neighbour blit to kMeterGrid^2
// picks on the GPU).
inline constexpr int kMeterGrid = 32;
int meterPixel(int i, int size) noexcept;
// The metered luminance (Rec. 709 weights) of the grid's radiance `rgb`
// (kMeterGrid^2 RGB triples, row j = 0 at the bottom) as the sensor sees it at
// exposure 1 (times vignetting): the mean over the mask (each point weighted
// by its coverage) mixed with the 95th percentile by camera.auto_peak.
float meterLuminance(const float* rgb, const FrameSetup& frame);
// The veiling glare of the same grid: camera.flare x the mean radiance over
// the mask (coverage-weighted) as the sensor sees it at exposure 1 (times
// vignetting), per channel; camera.glsl adds it to every pixel. Zero when
// camera.flare is 0.
std::array<float, 3> veilingGlare(const float* rgb, const FrameSetup& frame);
// Whether the camera changes nothing: fixed exposure 2^0, no vignetting,
// mask, softness or noise, the linear response. The renderers then draw the
// photographic modes straight to the output, clamped, as before the camera
// existed (no HDR target, no post pass).
bool cameraIsIdentity(const ParamSet& p) noexcept;
// Sets the registry's camera group to the identity (every step off): the
// look of a renderer without the camera, e.g. to compare with one.
void setCameraIdentity(ParamSet& p);
// The linear exposure factor for this frame given its metered luminance;
// updates `state`. Fixed exposure (camera.auto_exposure 0): 2^exposure_ev.
float exposureFor(const FrameSetup& frame, float metered, ExposureState& state);
// The camera's response camera.tone_curve (0 linear, 1 BT.709, 2 sRGB): a
// sensor signal in [0, 1] to the display value, and back.
float toneCurve(float signal, int curve) noexcept;
float inverseToneCurve(float value, int curve) noexcept;
// camera.knee's highlight knee on a tone-curved value, and its inverse
// (shaders/camera.glsl kneeCurve, inverseKneeCurve); knee 1 = none.
float kneeCurve(float value, float knee) noexcept;
float inverseKneeCurve(float value, float knee) noexcept;

enum class Filter {
    Nearest,    // GL_NEAREST
    Linear,     // GL_LINEAR, no mipmaps
    Trilinear,  // GL_LINEAR_MIPMAP_LINEAR (GL only; the reference samples it as Linear)
    Mipmap,     // GL_LINEAR_MIPMAP_NEAREST (GL only; the reference samples it as Linear)
};
enum class Wrap { Repeat, Clamp };

// A texture as both renderers see it. Image rows are in file order: the first
// row is the top of the picture, v = 1 (docs/theory.md, "Conventions"); the GL
// renderer uploads rows bottom-up to match.
struct TextureView {
    const image::Image8* image = nullptr;  // 1-4 channels; nullptr = the default below
    Filter filter = Filter::Linear;
    Wrap wrap = Wrap::Repeat;
};

struct Textures {
    TextureView diffuse;      // default: white
    TextureView reflectance;  // default: flat, rgb = (0.5, 0.5, 1)
    TextureView highlight;    // default: black (no highlight)
};

// RGB of `t` at texture coordinates (u, v), as OpenGL samples it
// (Nearest/Linear), in [0, 1].
std::array<float, 3> sampleTexture(const TextureView& t, float u, float v, std::array<float, 3> fallback) noexcept;

// Size of the automatically generated multitexture highlight texture.
inline constexpr int kHighlightTextureSize = 256;

// The multitexture baseline's highlight texture: a sphere-map image (1
// channel) of the Phong lobe (R . V)^n around the pole V (see highlightCoord
// in shaders/common_shading.glsl). Row order as files (first row = t = 1).
image::Image8 highlightSphereMap(int size, float shininess);

// Whether the frame's mode reads texture coordinates and tangents (the map,
// the patient texture, texture-space noise, the debug views of them). The
// others render meshes that have neither (vertex-phong, multitexture,
// diffuse, depth, procedural in object space).
bool modeNeedsUvs(const FrameSetup& f) noexcept;

// Renders `mesh` (positions and normals; uvs and tangents when
// modeNeedsUvs) into an RGB8 image, first row = top, background black. The
// photographic modes go through the camera (camera.glsl), with auto-exposure
// state from `exposure` (a camera path passes the same state for every frame;
// nullptr: a fresh state). Throws InputError if the mesh lacks what the mode needs.
image::Image8 renderReference(const mesh::Mesh& mesh, const FrameSetup& frame, const Textures& textures,
                              ExposureState* exposure = nullptr);

}  // namespace mucosa::shading
