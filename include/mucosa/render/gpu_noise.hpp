#pragma once
// The procedural path's noise evaluated on the GPU at given points, one point
// per pixel of a 32-bit float target: the check that the GLSL the renderer
// runs (shaders/procedural_noise.glsl) computes what mucosa::noise computes,
// and a way to bake procedural noise on the GPU. Needs a current OpenGL 3.3
// context (HeadlessContext or a window).
#include <array>
#include <span>
#include <vector>

#include <mucosa/shading/reference.hpp>

namespace mucosa::render {

enum class GpuNoiseFunction {
    Noise,         // perlinNoiseGradient(p, period): n and its gradient (noise::perlinGradient / ...PeriodicGradient)
    FractalUv,     // the map's fractal sum at (u, v) = (p.x, p.y) (noise::fractalGradient)
    FractalSolid,  // the solid fractal sum at p (noise::solidFractalGradient)
};

struct GpuNoiseRequest {
    GpuNoiseFunction function = GpuNoiseFunction::Noise;
    noise::FractalParams params;               // the fractal sums' parameters; `seed` also for Noise
    std::array<int, 3> period{256, 256, 256};  // Noise only: lattice periods (256 = plain noise)
};

// (value, d/dx, d/dy, d/dz) at each point. Throws GraphicsError if the
// shader or the float target is unavailable, InputError on invalid params.
std::vector<std::array<float, 4>> evaluateNoiseOnGpu(const GpuNoiseRequest& request,
                                                     std::span<const std::array<float, 3>> points);

}  // namespace mucosa::render
