#pragma once
// Sub-surface scattering of the mucosa (shaders/scatter.glsl; docs/theory.md,
// "Light under the mucosa"): Burley's normalised diffusion profile, its
// marginal along a line (the 1D kernel of the screen-space passes), the
// taps the passes take, and the passes themselves on the CPU (the C++
// reference of scatter.frag).
#include <array>
#include <vector>

#include <mucosa/shading/params.hpp>

namespace mucosa::shading {

struct FrameSetup;

inline constexpr int kScatterTaps = 11;  // per pass: the centre and 5 each side (scatter.glsl)

// R(r) = (e^(-r/d) + e^(-r/3d)) / (8 pi d r): light leaving the surface per
// unit area at distance r (mm) from where a unit of it entered, for the
// distance d (mm). Its integral over the plane is 1.
double diffusionProfile(double r, double d);
// Its integral along a line at distance x from the entry point:
// (K0(|x|/d) + K0(|x|/3d)) / (4 pi d). Its integral over x is 1.
double diffusionMarginal(double x, double d);

// The taps of one pass for the distances d (mm per channel; the largest sets
// the spacing): offsets in mm, quadratically spaced out to 10 d, and per
// channel the marginal's integral over each tap's interval, normalised to
// sum to 1 per channel (the tail beyond 10 d, 1 % for the widest channel,
// goes to the others in proportion). A channel with d = 0 gets the centre
// alone.
struct ScatterKernel {
    std::array<float, kScatterTaps> offsetMm{};
    std::array<std::array<float, 3>, kScatterTaps> weight{};
};
ScatterKernel scatterKernel(const std::array<float, 3>& distanceMm);

// The frame's body light diffuses: a mode that scatters (its body light and
// specular apart) with a scatter distance and share above 0.
bool scattersLight(const FrameSetup& frame) noexcept;

// The passes of scatter.frag (the diffusion along x and y at half size, then
// the full-size mix) on a perspective image of w x h pixels (rows bottom-up,
// as OpenGL): `bodySpecular` 4 floats per pixel (body light rgb, specular),
// `windowDepth` per pixel in [0, 1] (1: no surface, 0: the occluder outside
// the scope's mask); `projection` the
// frame's (column-major), whose focal lengths and near and far planes turn
// millimetres into pixels; `share` of the body light diffuses. Returns the
// radiance, 3 floats per pixel: the body light (scatterMix of the scattered
// and the kept) plus the specular.
std::vector<float> applyScatter(const std::vector<float>& bodySpecular, const std::vector<float>& windowDepth, int w,
                                int h, const std::array<float, 16>& projection, const ScatterKernel& kernel,
                                float share);

}  // namespace mucosa::shading
