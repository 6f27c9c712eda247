#include <mucosa/reflectance/normal_map.hpp>

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/parallel.hpp>

#include "core/simd.hpp"

namespace mucosa::reflectance {

namespace {

// Neighbour columns/rows and the distance between them, in texels.
struct Stencil {
    int lo, hi, span;
};

inline Stencil stencil(int i, int n, Edges edges) noexcept {
    if (n == 1) return {0, 0, 0};
    if (edges == Edges::Wrap) return {(i - 1 + n) % n, (i + 1) % n, 2};
    const int lo = std::max(i - 1, 0), hi = std::min(i + 1, n - 1);
    return {lo, hi, hi - lo};
}

// Paper eq. 1-2 with central differences; derivatives per map width/height.
inline std::array<double, 3> normalFrom(const float* H, int w, int h, int x, int y, double strength, const Stencil& sx,
                                        const Stencil& sy) noexcept {
    const auto at = [&](int xx, int yy) { return static_cast<double>(H[static_cast<std::size_t>(yy) * w + xx]); };
    const double su = sx.span ? strength * w / sx.span : 0.0;
    const double sv = sy.span ? strength * h / sy.span : 0.0;
    const double Hu = su * (at(sx.hi, y) - at(sx.lo, y));
    const double Hv = sv * (at(x, sy.lo) - at(x, sy.hi));  // +v points to the first row
    const double inv = 1.0 / std::sqrt(Hu * Hu + Hv * Hv + 1.0);
    return {-Hu * inv, -Hv * inv, inv};
}

// Round to nearest; N's components are in [-1, 1] so no clamp is needed, but
// keep one for safety against rounding at the ends.
inline std::uint8_t quantize8(double c) noexcept {
    const double q = std::floor((0.5 * c + 0.5) * 255.0 + 0.5);
    return static_cast<std::uint8_t>(static_cast<int>(q < 0.0 ? 0.0 : (q > 255.0 ? 255.0 : q)));
}

inline std::uint16_t quantize16(double c) noexcept {
    const double q = std::floor((0.5 * c + 0.5) * 65535.0 + 0.5);
    return static_cast<std::uint16_t>(static_cast<int>(q < 0.0 ? 0.0 : (q > 65535.0 ? 65535.0 : q)));
}

template <class T>
inline T quantize(double c) noexcept {
    if constexpr (sizeof(T) == 1)
        return quantize8(c);
    else
        return quantize16(c);
}

// Interior columns of one row: the same arithmetic as normalFrom with span 2,
// split into a normal pass and a quantise pass so that both vectorise.
template <class T>
__attribute__((always_inline)) inline void interiorRow(const float* __restrict up, const float* __restrict mid,
                                                       const float* __restrict down, int w, double su, double sv,
                                                       T* __restrict row) {
    constexpr int kChunk = 256;
    alignas(64) double nx[kChunk], ny[kChunk], nz[kChunk];
    for (int x0 = 1; x0 < w - 1; x0 += kChunk) {
        const int n = std::min(kChunk, w - 1 - x0);
        for (int i = 0; i < n; ++i) {
            const int x = x0 + i;
            const double Hu = su * (static_cast<double>(mid[x + 1]) - static_cast<double>(mid[x - 1]));
            const double Hv = sv * (static_cast<double>(up[x]) - static_cast<double>(down[x]));
            const double inv = 1.0 / std::sqrt(Hu * Hu + Hv * Hv + 1.0);
            nx[i] = -Hu * inv;
            ny[i] = -Hv * inv;
            nz[i] = inv;
        }
        T* dst = row + 3 * x0;
        for (int i = 0; i < n; ++i) {
            dst[3 * i] = quantize<T>(nx[i]);
            dst[3 * i + 1] = quantize<T>(ny[i]);
            dst[3 * i + 2] = quantize<T>(nz[i]);
        }
    }
}

MUCOSA_TARGET_CLONES void interiorRow8(const float* up, const float* mid, const float* down, int w, double su,
                                       double sv, std::uint8_t* row) {
    interiorRow(up, mid, down, w, su, sv, row);
}

MUCOSA_TARGET_CLONES void interiorRow16(const float* up, const float* mid, const float* down, int w, double su,
                                        double sv, std::uint16_t* row) {
    interiorRow(up, mid, down, w, su, sv, row);
}

template <class T>
void encodeRow(const image::ImageF& H, int y, double strength, Edges edges, T* row) {
    const int w = H.width(), h = H.height();
    const Stencil sy = stencil(y, h, edges);
    const double sv = sy.span ? strength * h / sy.span : 0.0;
    const double su = strength * w / 2.0;  // as normalFrom with span 2
    if constexpr (sizeof(T) == 1)
        interiorRow8(H.row(sy.lo), H.row(y), H.row(sy.hi), w, su, sv, row);
    else
        interiorRow16(H.row(sy.lo), H.row(y), H.row(sy.hi), w, su, sv, row);
    for (int x : {0, w - 1}) {
        const auto N = normalFrom(H.data(), w, h, x, y, strength, stencil(x, w, edges), sy);
        row[3 * x] = quantize<T>(N[0]);
        row[3 * x + 1] = quantize<T>(N[1]);
        row[3 * x + 2] = quantize<T>(N[2]);
    }
}

template <class T>
image::Image<T> encodeAll(const image::ImageF& H, double strength, Edges edges, int threads) {
    image::Image<T> out(H.width(), H.height(), 3);
    tbb::task_arena arena(resolveThreads(threads));
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<int>(0, H.height(), 16), [&](const tbb::blocked_range<int>& r) {
            for (int y = r.begin(); y < r.end(); ++y) encodeRow(H, y, strength, edges, out.row(y));
        });
    });
    return out;
}

}  // namespace

std::array<double, 3> normalAt(const image::ImageF& H, int x, int y, double strength, Edges edges) noexcept {
    return normalFrom(H.data(), H.width(), H.height(), x, y, strength, stencil(x, H.width(), edges),
                      stencil(y, H.height(), edges));
}

std::array<std::uint8_t, 3> encode8(const std::array<double, 3>& N) noexcept {
    return {quantize8(N[0]), quantize8(N[1]), quantize8(N[2])};
}

std::array<std::uint16_t, 3> encode16(const std::array<double, 3>& N) noexcept {
    return {quantize16(N[0]), quantize16(N[1]), quantize16(N[2])};
}

std::array<double, 3> decode(const std::array<double, 3>& rgb) noexcept {
    std::array<double, 3> N{2 * rgb[0] - 1, 2 * rgb[1] - 1, 2 * rgb[2] - 1};
    const double len = std::sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2]);
    if (len > 0)
        for (double& c : N) c /= len;
    return N;
}

std::array<double, 3> decode8(std::uint8_t r, std::uint8_t g, std::uint8_t b) noexcept {
    return decode({r / 255.0, g / 255.0, b / 255.0});
}

std::array<double, 3> decode16(std::uint16_t r, std::uint16_t g, std::uint16_t b) noexcept {
    return decode({r / 65535.0, g / 65535.0, b / 65535.0});
}

void encodeNormalRow8(const image::ImageF& H, int y, double strength, Edges edges, std::uint8_t* row) {
    encodeRow(H, y, strength, edges, row);
}

void encodeNormalRow16(const image::ImageF& H, int y, double strength, Edges edges, std::uint16_t* row) {
    encodeRow(H, y, strength, edges, row);
}

image::Image8 encodeNormals8(const image::ImageF& H, double strength, Edges edges, int threads) {
    return encodeAll<std::uint8_t>(H, strength, edges, threads);
}

image::Image16 encodeNormals16(const image::ImageF& H, double strength, Edges edges, int threads) {
    return encodeAll<std::uint16_t>(H, strength, edges, threads);
}

}  // namespace mucosa::reflectance
