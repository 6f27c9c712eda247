#include <mucosa/noise/perlin.hpp>

#include <mucosa/noise/gradient.hpp>

#include <cmath>
#include <limits>

namespace mucosa::noise {

namespace {

// Perlin 2002, ImprovedNoise.java: the reference permutation.
constexpr std::array<std::uint8_t, 256> kReference = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225, 140, 36,  103, 30,  69,  142,
    8,   99,  37,  240, 21,  10,  23,  190, 6,   148, 247, 120, 234, 75,  0,   26,  197, 62,  94,  252, 219, 203,
    117, 35,  11,  32,  57,  177, 33,  88,  237, 149, 56,  87,  174, 20,  125, 136, 171, 168, 68,  175, 74,  165,
    71,  134, 139, 48,  27,  166, 77,  146, 158, 231, 83,  111, 229, 122, 60,  211, 133, 230, 220, 105, 92,  41,
    55,  46,  245, 40,  244, 102, 143, 54,  65,  25,  63,  161, 1,   216, 80,  73,  209, 76,  132, 187, 208, 89,
    18,  169, 200, 196, 135, 130, 116, 188, 159, 86,  164, 100, 109, 198, 173, 186, 3,   64,  52,  217, 226, 250,
    124, 123, 5,   202, 38,  147, 118, 126, 255, 82,  85,  212, 207, 206, 59,  227, 47,  16,  58,  17,  182, 189,
    28,  42,  223, 183, 170, 213, 119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101, 155, 167, 43,  172, 9,
    129, 22,  39,  253, 19,  98,  108, 110, 79,  113, 224, 232, 178, 185, 112, 104, 218, 246, 97,  228, 251, 34,
    242, 193, 238, 210, 144, 12,  191, 179, 162, 241, 81,  51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,
    181, 199, 106, 157, 184, 84,  204, 176, 115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,  222, 114,
    67,  29,  24,  72,  243, 141, 128, 195, 78,  66,  215, 61,  156, 180};

std::uint64_t splitmix64(std::uint64_t& state) noexcept {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// The eight corner hashes of Perlin 2002, with the lattice indices already
// reduced (X0, X1 = next corner, etc.), in the order the interpolation takes
// them: (000, 100, 010, 110, 001, 101, 011, 111). Shared by the plain and the
// periodic variant; the plain one passes X1 = X0 + 1, which the doubled table
// absorbs exactly as the Java code does.
struct Corners {
    int h[8];
};

inline Corners cornerHashes(const std::uint8_t* p, int X0, int X1, int Y0, int Y1, int Z0, int Z1) noexcept {
    const int A = p[X0] + Y0, AA = p[A] + Z0, AB = p[p[X0] + Y1] + Z0;
    const int B = p[X1] + Y0, BA = p[B] + Z0, BB = p[p[X1] + Y1] + Z0;
    const int AAz = p[A] + Z1, ABz = p[p[X0] + Y1] + Z1;
    const int BAz = p[B] + Z1, BBz = p[p[X1] + Y1] + Z1;
    return {{p[AA], p[BA], p[AB], p[BB], p[AAz], p[BAz], p[ABz], p[BBz]}};
}

inline double evaluate(const std::uint8_t* p, int X0, int X1, int Y0, int Y1, int Z0, int Z1, double x, double y,
                       double z) noexcept {
    const double u = fade(x), v = fade(y), w = fade(z);
    const Corners c = cornerHashes(p, X0, X1, Y0, Y1, Z0, Z1);
    return lerp(w,
                lerp(v, lerp(u, grad(c.h[0], x, y, z), grad(c.h[1], x - 1, y, z)),
                     lerp(u, grad(c.h[2], x, y - 1, z), grad(c.h[3], x - 1, y - 1, z))),
                lerp(v, lerp(u, grad(c.h[4], x, y, z - 1), grad(c.h[5], x - 1, y, z - 1)),
                     lerp(u, grad(c.h[6], x, y - 1, z - 1), grad(c.h[7], x - 1, y - 1, z - 1))));
}

// The gradient vector behind grad(hash, ...): grad(h, x, y, z) = g . (x, y, z).
inline std::array<double, 3> gradVector(int hash) noexcept {
    return {grad(hash, 1, 0, 0), grad(hash, 0, 1, 0), grad(hash, 0, 0, 1)};
}

inline double fadeDerivative(double t) noexcept {
    return 30.0 * t * t * (t * (t - 2.0) + 1.0);
}

// evaluate() and its gradient; the value by the same operations in the same
// order (so it is bit-identical), the gradient by the product rule.
NoiseGradient evaluateGradient(const std::uint8_t* p, int X0, int X1, int Y0, int Y1, int Z0, int Z1, double x,
                               double y, double z) noexcept {
    const double u = fade(x), v = fade(y), w = fade(z);
    const Corners c = cornerHashes(p, X0, X1, Y0, Y1, Z0, Z1);
    const double a = grad(c.h[0], x, y, z), b = grad(c.h[1], x - 1, y, z);
    const double cc = grad(c.h[2], x, y - 1, z), d = grad(c.h[3], x - 1, y - 1, z);
    const double e = grad(c.h[4], x, y, z - 1), f = grad(c.h[5], x - 1, y, z - 1);
    const double g = grad(c.h[6], x, y - 1, z - 1), h = grad(c.h[7], x - 1, y - 1, z - 1);
    const double x1 = lerp(u, a, b), x2 = lerp(u, cc, d), x3 = lerp(u, e, f), x4 = lerp(u, g, h);
    const double y1 = lerp(v, x1, x2), y2 = lerp(v, x3, x4);
    NoiseGradient r;
    r.value = lerp(w, y1, y2);
    double blend[3];
    for (int k = 0; k < 3; ++k) {
        const auto gk = [&](int i) { return gradVector(c.h[i])[static_cast<std::size_t>(k)]; };
        blend[k] = lerp(w, lerp(v, lerp(u, gk(0), gk(1)), lerp(u, gk(2), gk(3))),
                        lerp(v, lerp(u, gk(4), gk(5)), lerp(u, gk(6), gk(7))));
    }
    const double du = fadeDerivative(x), dv = fadeDerivative(y), dw = fadeDerivative(z);
    r.dx = blend[0] + du * lerp(w, lerp(v, b - a, d - cc), lerp(v, f - e, h - g));
    r.dy = blend[1] + dv * lerp(w, x2 - x1, x4 - x3);
    r.dz = blend[2] + dw * (y2 - y1);
    return r;
}

inline int wrap(int i, int period) noexcept {
    const int m = i % period;
    return m < 0 ? m + period : m;
}

}  // namespace

int floorToInt(double x) noexcept {
    const double f = std::floor(x);
    if (!(f == f)) return 0;
    if (f >= 2147483647.0) return std::numeric_limits<int>::max();
    if (f <= -2147483648.0) return std::numeric_limits<int>::min();
    return static_cast<int>(f);
}

Permutation Permutation::fromSeed(std::uint64_t seed) noexcept {
    Permutation perm;
    perm.seed_ = seed;
    std::array<std::uint8_t, 256> t = kReference;
    if (seed != 0) {
        std::uint64_t state = seed;
        for (int i = 255; i > 0; --i) {
            const auto j = static_cast<int>(splitmix64(state) % static_cast<std::uint64_t>(i + 1));
            std::swap(t[static_cast<unsigned>(i)], t[static_cast<unsigned>(j)]);
        }
    }
    for (unsigned i = 0; i < 256; ++i) perm.p_[i] = perm.p_[i + 256] = t[i];
    return perm;
}

const Permutation& Permutation::reference() noexcept {
    static const Permutation ref = fromSeed(0);
    return ref;
}

double perlin(const Permutation& perm, double x, double y, double z) noexcept {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return 0.0;
    // Perlin 2002: FIND UNIT CUBE THAT CONTAINS POINT, then relative position.
    const int X = floorToInt(x) & 255, Y = floorToInt(y) & 255, Z = floorToInt(z) & 255;
    x -= std::floor(x);
    y -= std::floor(y);
    z -= std::floor(z);
    return evaluate(perm.table().data(), X, X + 1, Y, Y + 1, Z, Z + 1, x, y, z);
}

double perlin(double x, double y, double z) noexcept {
    return perlin(Permutation::reference(), x, y, z);
}

namespace {

// The periodic lattice of perlinPeriodic: reduced cells and fractions.
struct PeriodicCell {
    int X0, X1, Y0, Y1, Z0, Z1;
    double x, y, z;
};

PeriodicCell periodicCell(double x, double y, double z, int px, int py, int pz) noexcept {
    px = px < 1 ? 1 : (px > 256 ? 256 : px);
    py = py < 1 ? 1 : (py > 256 ? 256 : py);
    pz = pz < 1 ? 1 : (pz > 256 ? 256 : pz);
    const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
    // fmod keeps huge coordinates exact before the integer conversion.
    const int X0 = wrap(floorToInt(std::fmod(fx, px)), px);
    const int Y0 = wrap(floorToInt(std::fmod(fy, py)), py);
    const int Z0 = wrap(floorToInt(std::fmod(fz, pz)), pz);
    return {X0, (X0 + 1) % px, Y0, (Y0 + 1) % py, Z0, (Z0 + 1) % pz, x - fx, y - fy, z - fz};
}

}  // namespace

double perlinPeriodic(const Permutation& perm, double x, double y, double z, int px, int py, int pz) noexcept {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return 0.0;
    const PeriodicCell c = periodicCell(x, y, z, px, py, pz);
    return evaluate(perm.table().data(), c.X0, c.X1, c.Y0, c.Y1, c.Z0, c.Z1, c.x, c.y, c.z);
}

NoiseGradient perlinGradient(const Permutation& perm, double x, double y, double z) noexcept {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return {};
    const int X = floorToInt(x) & 255, Y = floorToInt(y) & 255, Z = floorToInt(z) & 255;
    x -= std::floor(x);
    y -= std::floor(y);
    z -= std::floor(z);
    return evaluateGradient(perm.table().data(), X, X + 1, Y, Y + 1, Z, Z + 1, x, y, z);
}

NoiseGradient perlinPeriodicGradient(const Permutation& perm, double x, double y, double z, int px, int py,
                                     int pz) noexcept {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return {};
    const PeriodicCell c = periodicCell(x, y, z, px, py, pz);
    return evaluateGradient(perm.table().data(), c.X0, c.X1, c.Y0, c.Y1, c.Z0, c.Z1, c.x, c.y, c.z);
}

double perlinGradientComponentVariance() noexcept {
    // A 64^3 stratified sample of one period-free block of the lattice (the
    // Weyl sequence jitters each point inside its stratum): E[(dn/dx)^2] and
    // the mean, which is 0 by symmetry up to sampling error.
    constexpr int kN = 64;
    double sum = 0, sum2 = 0;
    double jitter = 0.5;
    for (int i = 0; i < kN; ++i)
        for (int j = 0; j < kN; ++j)
            for (int k = 0; k < kN; ++k) {
                jitter += 0.6180339887498949;
                jitter -= std::floor(jitter);
                const double x = 16.0 * (i + jitter) / kN + 0.31, y = 16.0 * (j + 0.5) / kN + 0.47;
                const double z = 16.0 * (k + 0.5) / kN + 0.13;
                const double d = perlinGradient(Permutation::reference(), x, y, z).dx;
                sum += d;
                sum2 += d * d;
            }
    const double n = double(kN) * kN * kN;
    return sum2 / n - (sum / n) * (sum / n);
}

}  // namespace mucosa::noise
