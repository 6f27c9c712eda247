#pragma once
// Fractal sums of improved noise ("adding successive noise functions", the
// paper's Fig. 1a), over a 2D map parameterised by u, v in [0, 1):
//   H(u, v) = sum_{i < octaves} gain^i * n(f_i * u, f_i * v, z),
//   f_i = frequency * lacunarity^i,
// with n = Perlin 2002 noise (fBm) or |noise| (turbulence, Perlin 1985).
// The sums are accumulated octave by octave with running products
// (f *= lacunarity, a *= gain), in this order, by every path.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <mucosa/noise/perlin.hpp>

namespace mucosa::noise {

struct FractalParams {
    double frequency = 8.0;   // cycles of the base octave across the map
    int octaves = 6;          // number of octaves summed
    double lacunarity = 2.0;  // frequency ratio between octaves
    double gain = 0.5;        // amplitude ratio between octaves
    std::uint64_t seed = 0;   // permutation seed; 0 = Perlin's reference table
    // The slice z = const of 3D noise that is sampled. Not an integer: on
    // integer slices every z-gradient term vanishes and only the lattice-aligned
    // xy parts remain, which shows as axis-aligned creases (docs/cli.md, mucosa map, "Presets").
    double z = 0.5;
    bool turbulence = false;  // sum |noise| instead of noise
    bool tileable = false;    // periodic lattice: opposite edges meet seamlessly
};

// Throws InputError naming the parameter when `p` cannot be evaluated:
// non-finite or non-positive frequency/lacunarity, gain not finite or < 0,
// octaves outside 1..32, or (tileable) a frequency or lacunarity that is not a
// whole number, or an octave period above 256 that is not a multiple of 256.
void validate(const FractalParams& p);

// Number of octaves whose frequency stays at or below the Nyquist limit of a
// map `size` texels across (f_i <= size / 2).
int resolvableOctaves(const FractalParams& p, int size);

// The lattice period of octave i in a tileable map (f_i, reduced to 256 when it
// is a multiple of 256; the table repeats every 256 cells).
int octavePeriod(const FractalParams& p, int octave);

// Scalar reference: one map sample at (u, v). The fast path below is checked
// against this, sample by sample.
double fractal(const FractalParams& p, const Permutation& perm, double u, double v) noexcept;
double fractal(const FractalParams& p, double u, double v) noexcept;

struct FillOptions {
    int threads = 0;  // 0 = all hardware threads
};

// The fast path: fills a width x height map, row-major, sample (x, y) at
// u = x / width, v = y / height. Vectorised (AVX-512 / AVX2 / SSE2 chosen at
// run time) and multi-threaded over rows. The double version equals fractal()
// exactly (up to the sign of zero); the float version stays within 1e-5 of it.
// Output is identical for every thread count.
void fillFractal(const FractalParams& p, std::span<double> out, int width, int height, const FillOptions& options = {});
void fillFractal(const FractalParams& p, std::span<float> out, int width, int height, const FillOptions& options = {});

// Which instruction set the fast path dispatched to on this machine
// ("avx512f", "avx2" or "default").
std::string fastPathIsa();

}  // namespace mucosa::noise
