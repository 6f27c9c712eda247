#pragma once
// Improved noise and fractal sums with their analytic gradients (no finite
// differences): the double-precision reference for the run-time procedural
// path (shaders/procedural_noise.glsl, docs/theory.md "Procedural noise").
// Values equal perlin(), perlinPeriodic() and fractal() exactly: the value is
// computed by the same operations in the same order, the gradient alongside.
#include <mucosa/noise/fractal.hpp>
#include <mucosa/noise/perlin.hpp>

namespace mucosa::noise {

struct NoiseGradient {
    double value = 0;
    double dx = 0, dy = 0, dz = 0;  // partial derivatives by x, y, z
};

// n(x, y, z) and its gradient. The gradient of the fade-interpolated lattice:
// sum of the eight corner gradients weighted as the values are, plus the fade
// derivative 30 t^2 (t - 1)^2 times the difference along each axis.
NoiseGradient perlinGradient(const Permutation& p, double x, double y, double z) noexcept;
// The periodic variant (periods 1..256, as perlinPeriodic).
NoiseGradient perlinPeriodicGradient(const Permutation& p, double x, double y, double z, int px, int py,
                                     int pz) noexcept;

// A map sample H(u, v) of fractal() with dH/du, dH/dv (dz = 0: the slice z is
// fixed). Turbulence's |n| is differentiated as sign(n) grad n.
NoiseGradient fractalGradient(const FractalParams& p, const Permutation& perm, double u, double v) noexcept;

// Solid fractal noise, for object-space texturing without texture
// coordinates: H(q) = sum_i gain^i n(f_i q) over 3D points q (p.z and
// p.tileable are not used), with its gradient in q.
NoiseGradient solidFractalGradient(const FractalParams& p, const Permutation& perm, double x, double y,
                                   double z) noexcept;

// The variance of one component of grad n (improved noise, reference table),
// over uniformly distributed points: the slope energy one octave of unit
// amplitude and frequency contributes. Used by the procedural path's
// anti-aliasing to widen the highlight by the slope variance of the octaves
// it fades out (docs/theory.md). Measured once (a fixed quasi-random sample).
double perlinGradientComponentVariance() noexcept;

}  // namespace mucosa::noise
