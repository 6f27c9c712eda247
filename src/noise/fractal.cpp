#include <mucosa/noise/fractal.hpp>

#include <mucosa/noise/gradient.hpp>

#include <cmath>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>

namespace mucosa::noise {

namespace {
bool isWhole(double x) {
    return std::isfinite(x) && std::floor(x) == x;
}
}  // namespace

void validate(const FractalParams& p) {
    if (!std::isfinite(p.frequency) || p.frequency <= 0)
        throw InputError("frequency", "", fmt::format("must be a positive number, got {}", p.frequency));
    if (!std::isfinite(p.lacunarity) || p.lacunarity <= 0)
        throw InputError("lacunarity", "", fmt::format("must be a positive number, got {}", p.lacunarity));
    if (!std::isfinite(p.gain) || p.gain < 0)
        throw InputError("gain", "", fmt::format("must be a number >= 0, got {}", p.gain));
    if (p.octaves < 1 || p.octaves > 32)
        throw InputError("octaves", "", fmt::format("must be in 1..32, got {}", p.octaves));
    if (!std::isfinite(p.z)) throw InputError("z", "", "must be finite");
    double f = p.frequency;
    for (int i = 0; i < p.octaves; ++i, f *= p.lacunarity) {
        if (!std::isfinite(f) || f > 1e12)
            throw InputError("octaves", "", fmt::format("octave {} reaches frequency {}, too high to sample", i, f));
    }
    if (!p.tileable) return;
    if (!isWhole(p.frequency))
        throw InputError("frequency", "",
                         fmt::format("a tileable map needs a whole number of cycles, got {}", p.frequency));
    if (!isWhole(p.lacunarity))
        throw InputError("lacunarity", "",
                         fmt::format("a tileable map needs a whole-number lacunarity, got {}", p.lacunarity));
    f = p.frequency;
    for (int i = 0; i < p.octaves; ++i, f *= p.lacunarity) {
        if (f > 256 && std::fmod(f, 256.0) != 0)
            throw InputError(
                "frequency", "",
                fmt::format("octave {} has {} cycles: above 256 a tileable period must be a multiple of 256", i, f));
    }
}

int resolvableOctaves(const FractalParams& p, int size) {
    int n = 0;
    double f = p.frequency;
    for (int i = 0; i < p.octaves; ++i, f *= p.lacunarity)
        if (f <= size / 2.0) ++n;
    return n;
}

int octavePeriod(const FractalParams& p, int octave) {
    double f = p.frequency;
    for (int i = 0; i < octave; ++i) f *= p.lacunarity;
    if (f > 256) return 256;
    return static_cast<int>(f);
}

double fractal(const FractalParams& p, const Permutation& perm, double u, double v) noexcept {
    double sum = 0.0, f = p.frequency, a = 1.0;
    for (int i = 0; i < p.octaves; ++i) {
        double n;
        if (p.tileable) {
            const int period = f > 256 ? 256 : static_cast<int>(f);
            n = perlinPeriodic(perm, f * u, f * v, p.z, period, period, 256);
        } else {
            n = perlin(perm, f * u, f * v, p.z);
        }
        sum += a * (p.turbulence ? std::fabs(n) : n);
        f *= p.lacunarity;
        a *= p.gain;
    }
    return sum;
}

NoiseGradient fractalGradient(const FractalParams& p, const Permutation& perm, double u, double v) noexcept {
    NoiseGradient sum;
    double f = p.frequency, a = 1.0;
    for (int i = 0; i < p.octaves; ++i) {
        NoiseGradient n;
        if (p.tileable) {
            const int period = f > 256 ? 256 : static_cast<int>(f);
            n = perlinPeriodicGradient(perm, f * u, f * v, p.z, period, period, 256);
        } else {
            n = perlinGradient(perm, f * u, f * v, p.z);
        }
        const double s = p.turbulence && n.value < 0 ? -1.0 : 1.0;
        sum.value += a * (p.turbulence ? std::fabs(n.value) : n.value);
        sum.dx += a * s * f * n.dx;  // chain rule: d n(f u) / du = f n_x
        sum.dy += a * s * f * n.dy;
        f *= p.lacunarity;
        a *= p.gain;
    }
    return sum;
}

NoiseGradient solidFractalGradient(const FractalParams& p, const Permutation& perm, double x, double y,
                                   double z) noexcept {
    NoiseGradient sum;
    double f = p.frequency, a = 1.0;
    for (int i = 0; i < p.octaves; ++i) {
        const NoiseGradient n = perlinGradient(perm, f * x, f * y, f * z);
        const double s = p.turbulence && n.value < 0 ? -1.0 : 1.0;
        sum.value += a * s * n.value;
        sum.dx += a * s * f * n.dx;
        sum.dy += a * s * f * n.dy;
        sum.dz += a * s * f * n.dz;
        f *= p.lacunarity;
        a *= p.gain;
    }
    return sum;
}

double fractal(const FractalParams& p, double u, double v) noexcept {
    if (p.seed == 0) return fractal(p, Permutation::reference(), u, v);
    return fractal(p, Permutation::fromSeed(p.seed), u, v);
}

}  // namespace mucosa::noise
