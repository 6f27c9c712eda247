#pragma once
// Ken Perlin's improved noise (Perlin 2002, "Improving Noise", SIGGRAPH),
// bit-compatible with his Java reference ImprovedNoise.noise: the same
// permutation, fade 6t^5 - 15t^4 + 10t^3, 12-direction gradient set (16 hashed
// entries) and floor behaviour for negative coordinates.
#include <array>
#include <cstdint>

namespace mucosa::noise {

// Ken Perlin's Java reference, exactly: noise(3.14, 42, 7) = 0.13691995878400012.
// Zero at every integer lattice point, period 256 in each axis, range about
// [-1, 1]. Non-finite input returns 0 (Java would saturate; see docs/theory.md).
double perlin(double x, double y, double z) noexcept;

// A permutation of 0..255, stored twice (512 entries) as in the reference so
// that p[p[X] + Y] never wraps.
class Permutation {
public:
    // Seed 0 is Perlin's reference table; any other seed shuffles it with a
    // Fisher-Yates shuffle driven by SplitMix64(seed), deterministically on
    // every platform.
    static Permutation fromSeed(std::uint64_t seed) noexcept;
    static const Permutation& reference() noexcept;

    std::uint8_t operator[](int i) const noexcept { return p_[static_cast<unsigned>(i)]; }
    const std::array<std::uint8_t, 512>& table() const noexcept { return p_; }
    std::uint64_t seed() const noexcept { return seed_; }

private:
    std::array<std::uint8_t, 512> p_{};
    std::uint64_t seed_ = 0;
};

// Improved noise with the given permutation (perlin(Permutation::reference(), ...)
// == perlin(...)).
double perlin(const Permutation& p, double x, double y, double z) noexcept;

// Periodic improved noise: the lattice wraps with integer periods px, py, pz
// (each in 1..256), so noise(x + px, y, z) == noise(x, y, z). With all periods
// 256 it equals the plain noise.
double perlinPeriodic(const Permutation& p, double x, double y, double z, int px, int py, int pz) noexcept;

// The reference's building blocks (Perlin 2002), exposed so that the fast path
// and the GLSL port can be checked against them term by term.
constexpr double fade(double t) noexcept {
    return t * t * t * (t * (t * 6 - 15) + 10);
}
constexpr double lerp(double t, double a, double b) noexcept {
    return a + t * (b - a);
}
constexpr double grad(int hash, double x, double y, double z) noexcept {
    const int h = hash & 15;
    const double u = h < 8 ? x : y;
    const double v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
    return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
}

// Java's (int)Math.floor(x): saturates at the int range, NaN -> 0.
int floorToInt(double x) noexcept;

}  // namespace mucosa::noise
