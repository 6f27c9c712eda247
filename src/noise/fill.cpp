// The fast path of fillFractal (see fractal.hpp). Per octave, everything that
// depends only on the column (lattice cell X, fraction x, fade(x)) is computed
// once for the whole map; per row and lattice cell ("span"), the eight corner
// hashes turn each gradient grad(h, x, y, z) of Perlin 2002 into s * xq + C
// with s in {-1, 0, 1} and C holding the row's y and z terms. What remains per
// sample is a branch-free, gather-free loop of multiplies and adds in exactly
// the reference's order, which the compiler vectorises for the ISA chosen at
// run time (target_clones). Because IEEE addition is commutative and s * xq is
// exact, the double path reproduces Perlin's Java arithmetic bit for bit.
#include <mucosa/noise/fractal.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <thread>
#include <type_traits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/core/parallel.hpp>

#include "core/simd.hpp"

namespace mucosa::noise {

namespace {

// Aligned storage for the vector loops' arrays (LargeAllocator: at least 64
// bytes), so no load or store straddles a cache line.
template <class T>
using AlignedVector = std::vector<T, LargeAllocator<T>>;

struct Span {
    int begin, end;  // columns [begin, end) share lattice cell X0
    int X0, X1;
};

// Column data of one octave, shared by all rows.
template <class T>
struct Octave {
    double f = 0, a = 0;
    int period = 256;  // 256 = plain noise
    AlignedVector<T> xf, xf1, u;
    std::vector<Span> spans;
    // Float path: the folded corner gradients of every (lattice row Y0, span),
    // so a row needs no hashing (see buildCornerTables). Empty: hash per span.
    std::array<int, 256> ySlot{};
    std::vector<float> corners;  // [slot][kCornerFields][spans]
};

// Row constants of one octave: y, z fractions, their fades and lattice indices.
struct RowFrame {
    double yf, zf, v, w;
    int Y0, Y1, Z0, Z1;
};

inline int wrapIndex(int i, int period) noexcept {
    const int m = i % period;
    return m < 0 ? m + period : m;
}

// The row's lattice rows and slices and fractions, exactly as perlin() and
// perlinPeriodic() compute them (period 256 = plain noise).
inline RowFrame rowLattice(double y, double z, int period) noexcept {
    const double fy = std::floor(y), fz = std::floor(z);
    RowFrame r{};
    if (period == 256) {
        r.Y0 = floorToInt(y) & 255;
        r.Y1 = r.Y0 + 1;
        r.Z0 = floorToInt(z) & 255;
        r.Z1 = r.Z0 + 1;
    } else {
        r.Y0 = wrapIndex(floorToInt(std::fmod(fy, period)), period);
        r.Y1 = (r.Y0 + 1) % period;
        r.Z0 = wrapIndex(floorToInt(std::fmod(fz, 256.0)), 256);
        r.Z1 = (r.Z0 + 1) % 256;
    }
    r.yf = y - fy;
    r.zf = z - fz;
    r.v = fade(r.yf);
    r.w = fade(r.zf);
    return r;
}

// One lattice corner's gradient as s * xq + C (see the file comment).
struct Corner {
    double s, C;
};

inline Corner corner(int hash, double yq, double zq) noexcept {
    const int h = hash & 15;
    if (h < 8) {  // u = x; v = y (h < 4) or z
        const double vv = h < 4 ? yq : zq;
        return {(h & 1) == 0 ? 1.0 : -1.0, (h & 2) == 0 ? vv : -vv};
    }
    if (h == 12 || h == 14) {  // u = y, v = x
        return {(h & 2) == 0 ? 1.0 : -1.0, (h & 1) == 0 ? yq : -yq};
    }
    // u = y, v = z: no x term; C is the reference's sum itself.
    return {0.0, ((h & 1) == 0 ? yq : -yq) + ((h & 2) == 0 ? zq : -zq)};
}

template <class T>
struct SpanCoeffs {
    T s[8], C[8];
    T v, w, a;
};

// The per-sample loop: 8 gradients, 7 lerps, one accumulation, in Perlin 2002's
// order: lerp(w, lerp(v, lerp(u, g000, g100), lerp(u, g010, g110)),
//                lerp(v, lerp(u, g001, g101), lerp(u, g011, g111))).
template <class T, bool kTurbulence>
__attribute__((always_inline)) inline void spanKernel(T* __restrict acc, const T* __restrict xf,
                                                      const T* __restrict xf1, const T* __restrict uu, int n,
                                                      const SpanCoeffs<T>& k) {
    const T s0 = k.s[0], s1 = k.s[1], s2 = k.s[2], s3 = k.s[3];
    const T s4 = k.s[4], s5 = k.s[5], s6 = k.s[6], s7 = k.s[7];
    const T C0 = k.C[0], C1 = k.C[1], C2 = k.C[2], C3 = k.C[3];
    const T C4 = k.C[4], C5 = k.C[5], C6 = k.C[6], C7 = k.C[7];
    const T v = k.v, w = k.w, a = k.a;
    for (int i = 0; i < n; ++i) {
        const T x0 = xf[i], x1 = xf1[i], u = uu[i];
        const T g000 = s0 * x0 + C0, g100 = s1 * x1 + C1;
        const T g010 = s2 * x0 + C2, g110 = s3 * x1 + C3;
        const T g001 = s4 * x0 + C4, g101 = s5 * x1 + C5;
        const T g011 = s6 * x0 + C6, g111 = s7 * x1 + C7;
        const T l00 = g000 + u * (g100 - g000);
        const T l10 = g010 + u * (g110 - g010);
        const T l01 = g001 + u * (g101 - g001);
        const T l11 = g011 + u * (g111 - g011);
        const T m0 = l00 + v * (l10 - l00);
        const T m1 = l01 + v * (l11 - l01);
        const T nz = m0 + w * (m1 - m0);
        acc[i] += a * (kTurbulence ? std::fabs(nz) : nz);
    }
}

template <class T>
struct RowJob {
    const std::vector<Octave<T>>* octaves;
    const std::uint8_t* p;
    double z;
    bool turbulence;
};

template <class T>
__attribute__((always_inline)) inline void rowBody(const RowJob<T>& job, T* row, int width, double v) {
    std::fill(row, row + width, T(0));
    const std::uint8_t* p = job.p;
    for (const Octave<T>& oct : *job.octaves) {
        const RowFrame r = rowLattice(oct.f * v, job.z, oct.period);
        const double y1 = r.yf - 1, z1 = r.zf - 1;
        SpanCoeffs<T> k{};
        k.v = static_cast<T>(r.v);
        k.w = static_cast<T>(r.w);
        k.a = static_cast<T>(oct.a);
        for (const Span& sp : oct.spans) {
            const int A = p[sp.X0] + r.Y0, B = p[sp.X1] + r.Y0;
            const int A1 = p[sp.X0] + r.Y1, B1 = p[sp.X1] + r.Y1;
            // Corner order: g000, g100, g010, g110, g001, g101, g011, g111.
            const Corner c[8] = {corner(p[p[A] + r.Z0], r.yf, r.zf), corner(p[p[B] + r.Z0], r.yf, r.zf),
                                 corner(p[p[A1] + r.Z0], y1, r.zf),  corner(p[p[B1] + r.Z0], y1, r.zf),
                                 corner(p[p[A] + r.Z1], r.yf, z1),   corner(p[p[B] + r.Z1], r.yf, z1),
                                 corner(p[p[A1] + r.Z1], y1, z1),    corner(p[p[B1] + r.Z1], y1, z1)};
            for (int i = 0; i < 8; ++i) {
                k.s[i] = static_cast<T>(c[i].s);
                k.C[i] = static_cast<T>(c[i].C);
            }
            const int n = sp.end - sp.begin;
            if (job.turbulence)
                spanKernel<T, true>(row + sp.begin, oct.xf.data() + sp.begin, oct.xf1.data() + sp.begin,
                                    oct.u.data() + sp.begin, n, k);
            else
                spanKernel<T, false>(row + sp.begin, oct.xf.data() + sp.begin, oct.xf1.data() + sp.begin,
                                     oct.u.data() + sp.begin, n, k);
        }
    }
}

// The float path folds the whole trilinear blend into one cubic-free form per
// span. With g = gx*x + gy*y + gz*z for hash h (Perlin 2002's gradient set) and
// the row's y, z weights (v, w fixed per row and span), each x-lerp is
//   l = ga + u (gb - ga) = (sa x + Ca) + u ((sb - sa) x + (Cb - Ca)),
// so the octave's contribution a * n(x) = (P x + Q) + u (R x + S), three
// multiply-adds per sample. The map is a plane of constant z, so the z blend
// (and the amplitude a) is folded into the per-cell table once per octave; per
// row, P, Q, R, S are blends in v and y of twelve table fields per span. The
// algebra is exact; only float rounding differs from the reference, well inside
// the 1e-5 the tests hold it to.
struct GradTable {
    double gx[16], gy[16], gz[16];
    GradTable() {
        for (int h = 0; h < 16; ++h) {
            const double su = (h & 1) ? -1.0 : 1.0, sv = (h & 2) ? -1.0 : 1.0;
            gx[h] = gy[h] = gz[h] = 0.0;
            if (h < 8)
                gx[h] += su;
            else
                gy[h] += su;  // u = x or y
            if (h < 4)
                gy[h] += sv;  // v = y
            else if (h == 12 || h == 14)
                gx[h] += sv;  // v = x
            else
                gz[h] += sv;  // v = z
        }
    }
};
const GradTable kGrad;

// Table fields of one span for one lattice row Y (m = 0: the cell's lower
// row, 1: its upper), z blend and amplitude folded in:
//   PX = sum_z W gx(a), RX = sum_z W (gx(b) - gx(a)), QY = sum_z W gy(a),
//   QZ = sum_z W gz(a) zq, SY = sum_z W (gy(b) - gy(a)),
//   SZ = sum_z W ((gz(b) - gz(a)) zq - gx(b)),
// with W = a (1 - w), a w for the slices Z0, Z1 and zq = zf, zf - 1. Then
//   P = sum_m V PX, R = sum_m V RX, Q = sum_m V (yq QY + QZ),
//   S = sum_m V (yq SY + SZ), V = 1 - v, v and yq = yf, yf - 1.
constexpr int kRowFields = 6;
constexpr int kCornerFields = 2 * kRowFields;

struct SliceFold {
    int Z0, Z1;
    double W[2], zq[2];
};

SliceFold sliceFold(const Octave<float>& oct, double z) {
    const RowFrame r = rowLattice(0.0, z, oct.period);
    return {r.Z0, r.Z1, {oct.a * (1 - r.w), oct.a * r.w}, {r.zf, r.zf - 1}};
}

inline void rowFields(const std::uint8_t* p, int X0, int X1, int Y, const SliceFold& s, double f[kRowFields]) {
    for (int q = 0; q < kRowFields; ++q) f[q] = 0.0;
    const int Zs[2] = {s.Z0, s.Z1};
    for (int c = 0; c < 2; ++c) {
        const int ha = p[p[p[X0] + Y] + Zs[c]] & 15;
        const int hb = p[p[p[X1] + Y] + Zs[c]] & 15;
        const double W = s.W[c], zq = s.zq[c];
        f[0] += W * kGrad.gx[ha];
        f[1] += W * (kGrad.gx[hb] - kGrad.gx[ha]);
        f[2] += W * kGrad.gy[ha];
        f[3] += W * kGrad.gz[ha] * zq;
        f[4] += W * (kGrad.gy[hb] - kGrad.gy[ha]);
        f[5] += W * ((kGrad.gz[hb] - kGrad.gz[ha]) * zq - kGrad.gx[hb]);
    }
}

// Fills oct.corners for every lattice row the map's rows fall in (at most 256).
void buildCornerTables(Octave<float>& oct, const std::uint8_t* p, int height, double z) {
    constexpr std::size_t kMaxTableBytes = std::size_t{48} << 20;
    oct.ySlot.fill(-1);
    const std::size_t nsp = oct.spans.size();
    std::vector<RowFrame> rows;
    int slots = 0;
    for (int y = 0; y < height; ++y) {
        const RowFrame fr = rowLattice(oct.f * (static_cast<double>(y) / height), z, oct.period);
        if (oct.ySlot[static_cast<std::size_t>(fr.Y0)] < 0) {
            oct.ySlot[static_cast<std::size_t>(fr.Y0)] = slots++;
            rows.push_back(fr);
        }
    }
    if (static_cast<std::size_t>(slots) * nsp * kCornerFields * sizeof(float) > kMaxTableBytes) {
        oct.ySlot.fill(-1);
        return;  // too many cells for a table: hash per span instead
    }
    const SliceFold s = sliceFold(oct, z);
    oct.corners.assign(static_cast<std::size_t>(slots) * kCornerFields * nsp, 0.0f);
    for (int sl = 0; sl < slots; ++sl) {
        const RowFrame& fr = rows[static_cast<std::size_t>(sl)];
        float* t = oct.corners.data() + static_cast<std::size_t>(sl) * kCornerFields * nsp;
        for (std::size_t j = 0; j < nsp; ++j) {
            const Span& sp = oct.spans[j];
            const int Ys[2] = {fr.Y0, fr.Y1};
            for (int m = 0; m < 2; ++m) {
                double f[kRowFields];
                rowFields(p, sp.X0, sp.X1, Ys[m], s, f);
                for (int q = 0; q < kRowFields; ++q)
                    t[static_cast<std::size_t>(kRowFields * m + q) * nsp + j] = static_cast<float>(f[q]);
            }
        }
    }
}

template <bool kFma>
__attribute__((always_inline)) inline float madd(float a, float b, float c) {
    if constexpr (kFma)
        return __builtin_fmaf(a, b, c);
    else
        return a * b + c;
}

// Blend weights of one row: V0 = 1 - v, V1 = v, and V times yq.
struct RowBlend {
    float V0, V1, V0y, V1y;
};

// P, Q, R, S of every span of a row from the table (vectorised across spans).
template <bool kFma>
__attribute__((always_inline)) inline void rowCoefficients(const float* __restrict t, std::size_t nsp, RowBlend b,
                                                           float* __restrict P, float* __restrict Q,
                                                           float* __restrict R, float* __restrict S) {
    const float* px0 = t;
    const float* rx0 = t + nsp;
    const float* qy0 = t + 2 * nsp;
    const float* qz0 = t + 3 * nsp;
    const float* sy0 = t + 4 * nsp;
    const float* sz0 = t + 5 * nsp;
    const float* px1 = t + 6 * nsp;
    const float* rx1 = t + 7 * nsp;
    const float* qy1 = t + 8 * nsp;
    const float* qz1 = t + 9 * nsp;
    const float* sy1 = t + 10 * nsp;
    const float* sz1 = t + 11 * nsp;
    for (std::size_t j = 0; j < nsp; ++j) {
        P[j] = madd<kFma>(b.V1, px1[j], b.V0 * px0[j]);
        R[j] = madd<kFma>(b.V1, rx1[j], b.V0 * rx0[j]);
        Q[j] = madd<kFma>(b.V1y, qy1[j], madd<kFma>(b.V1, qz1[j], madd<kFma>(b.V0y, qy0[j], b.V0 * qz0[j])));
        S[j] = madd<kFma>(b.V1y, sy1[j], madd<kFma>(b.V1, sz1[j], madd<kFma>(b.V0y, sy0[j], b.V0 * sz0[j])));
    }
}

// Where an octave's samples go: the first octave writes the accumulator, the
// middle ones add to it, the last one adds and writes the caller's row (so the
// row is written once, with no separate copy); a single octave writes it.
enum class Pass { First, Middle, Last, Only };

// The per-sample loop.
template <bool kFma, bool kTurbulence, Pass kPass>
__attribute__((always_inline)) inline void foldedKernel(float* __restrict acc, float* __restrict dst,
                                                        const float* __restrict xf, const float* __restrict uu, int n,
                                                        float P, float Q, float R, float S) {
    for (int i = 0; i < n; ++i) {
        const float x = xf[i];
        const float val = madd<kFma>(uu[i], madd<kFma>(R, x, S), madd<kFma>(P, x, Q));
        const float term = kTurbulence ? std::fabs(val) : val;
        if constexpr (kPass == Pass::First)
            acc[i] = term;
        else if constexpr (kPass == Pass::Middle)
            acc[i] += term;
        else if constexpr (kPass == Pass::Last)
            dst[i] = acc[i] + term;
        else
            dst[i] = term;
    }
}

template <bool kFma, bool kTurbulence, Pass kPass>
__attribute__((always_inline)) inline void octaveSpans(const Octave<float>& oct, float* acc, float* dst, const float* P,
                                                       const float* Q, const float* R, const float* S) {
    const std::size_t nsp = oct.spans.size();
    for (std::size_t j = 0; j < nsp; ++j) {
        const Span& sp = oct.spans[j];
        foldedKernel<kFma, kTurbulence, kPass>(acc + sp.begin, dst + sp.begin, oct.xf.data() + sp.begin,
                                               oct.u.data() + sp.begin, sp.end - sp.begin, P[j], Q[j], R[j], S[j]);
    }
}

template <bool kFma, bool kTurbulence>
__attribute__((always_inline)) inline void octaveSpans(const Octave<float>& oct, Pass pass, float* acc, float* dst,
                                                       const float* P, const float* Q, const float* R, const float* S) {
    switch (pass) {
        case Pass::First:
            return octaveSpans<kFma, kTurbulence, Pass::First>(oct, acc, dst, P, Q, R, S);
        case Pass::Middle:
            return octaveSpans<kFma, kTurbulence, Pass::Middle>(oct, acc, dst, P, Q, R, S);
        case Pass::Last:
            return octaveSpans<kFma, kTurbulence, Pass::Last>(oct, acc, dst, P, Q, R, S);
        case Pass::Only:
            return octaveSpans<kFma, kTurbulence, Pass::Only>(oct, acc, dst, P, Q, R, S);
    }
}

template <bool kFma>
__attribute__((always_inline)) inline void rowBodyFolded(const RowJob<float>& job, float* acc, float* dst, double v,
                                                         std::vector<float>& scratch) {
    const std::uint8_t* p = job.p;
    const std::size_t count = job.octaves->size();
    for (std::size_t o = 0; o < count; ++o) {
        const Octave<float>& oct = (*job.octaves)[o];
        const RowFrame fr = rowLattice(oct.f * v, job.z, oct.period);
        const std::size_t nsp = oct.spans.size();
        const int slot = oct.ySlot[static_cast<std::size_t>(fr.Y0)];
        scratch.resize(4 * nsp);
        float* P = scratch.data();
        float* Q = P + nsp;
        float* R = Q + nsp;
        float* S = R + nsp;
        const double V[2] = {1 - fr.v, fr.v}, yq[2] = {fr.yf, fr.yf - 1};
        if (slot >= 0) {
            const RowBlend b{static_cast<float>(V[0]), static_cast<float>(V[1]), static_cast<float>(V[0] * yq[0]),
                             static_cast<float>(V[1] * yq[1])};
            rowCoefficients<kFma>(oct.corners.data() + static_cast<std::size_t>(slot) * kCornerFields * nsp, nsp, b, P,
                                  Q, R, S);
        } else {
            const SliceFold s = sliceFold(oct, job.z);
            const int Ys[2] = {fr.Y0, fr.Y1};
            for (std::size_t j = 0; j < nsp; ++j) {
                const Span& sp = oct.spans[j];
                double sum[4] = {0, 0, 0, 0};
                for (int m = 0; m < 2; ++m) {
                    double f[kRowFields];
                    rowFields(p, sp.X0, sp.X1, Ys[m], s, f);
                    sum[0] += V[m] * f[0];
                    sum[1] += V[m] * (yq[m] * f[2] + f[3]);
                    sum[2] += V[m] * f[1];
                    sum[3] += V[m] * (yq[m] * f[4] + f[5]);
                }
                P[j] = static_cast<float>(sum[0]);
                Q[j] = static_cast<float>(sum[1]);
                R[j] = static_cast<float>(sum[2]);
                S[j] = static_cast<float>(sum[3]);
            }
        }
        const Pass pass =
            count == 1 ? Pass::Only : (o == 0 ? Pass::First : (o + 1 == count ? Pass::Last : Pass::Middle));
        if (job.turbulence)
            octaveSpans<kFma, true>(oct, pass, acc, dst, P, Q, R, S);
        else
            octaveSpans<kFma, false>(oct, pass, acc, dst, P, Q, R, S);
    }
}

// One clone per ISA; glibc's ifunc resolver picks the best at load time.
#define MUCOSA_CLONES MUCOSA_TARGET_CLONES

MUCOSA_CLONES void rowsDouble(const RowJob<double>& job, double* out, int width, int height, int y0, int y1) {
    for (int y = y0; y < y1; ++y)
        rowBody(job, out + static_cast<std::size_t>(y) * width, width, static_cast<double>(y) / height);
}

template <bool kFma>
__attribute__((always_inline)) inline void rowsFloatBody(const RowJob<float>& job, float* out, int width, int height,
                                                         int y0, int y1) {
    // Octaves accumulate in an aligned row buffer; the last one writes the
    // caller's row.
    std::vector<float> scratch;
    AlignedVector<float> acc(static_cast<std::size_t>(width));
    for (int y = y0; y < y1; ++y)
        rowBodyFolded<kFma>(job, acc.data(), out + static_cast<std::size_t>(y) * width, static_cast<double>(y) / height,
                            scratch);
}

// The float path's multiply-adds are fused where the CPU has FMA (x86-64-v3 and
// v4); the rounding only improves. Elsewhere: one clone per ISA, plain mul+add.
MUCOSA_CLONES void rowsFloatPlain(const RowJob<float>& job, float* out, int width, int height, int y0, int y1) {
    rowsFloatBody<false>(job, out, width, height, y0, y1);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(__SANITIZE_ADDRESS__)
#define MUCOSA_FMA_PATHS 1
__attribute__((target("arch=x86-64-v3"))) void rowsFloatV3(const RowJob<float>& job, float* out, int width, int height,
                                                           int y0, int y1) {
    rowsFloatBody<true>(job, out, width, height, y0, y1);
}
__attribute__((target("arch=x86-64-v4"))) void rowsFloatV4(const RowJob<float>& job, float* out, int width, int height,
                                                           int y0, int y1) {
    rowsFloatBody<true>(job, out, width, height, y0, y1);
}
#endif

enum class FloatIsa { Plain, V3, V4 };

FloatIsa floatIsa() {
#ifdef MUCOSA_FMA_PATHS
    static const FloatIsa isa = [] {
        __builtin_cpu_init();
        const bool v3 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
        if (v3 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
            __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq"))
            return FloatIsa::V4;
        return v3 ? FloatIsa::V3 : FloatIsa::Plain;
    }();
    return isa;
#else
    return FloatIsa::Plain;
#endif
}

void rowsFloat(const RowJob<float>& job, float* out, int width, int height, int y0, int y1) {
#ifdef MUCOSA_FMA_PATHS
    switch (floatIsa()) {
        case FloatIsa::V4:
            return rowsFloatV4(job, out, width, height, y0, y1);
        case FloatIsa::V3:
            return rowsFloatV3(job, out, width, height, y0, y1);
        case FloatIsa::Plain:
            break;
    }
#endif
    rowsFloatPlain(job, out, width, height, y0, y1);
}

void rows(const RowJob<double>& job, double* out, int w, int h, int y0, int y1) {
    rowsDouble(job, out, w, h, y0, y1);
}
void rows(const RowJob<float>& job, float* out, int w, int h, int y0, int y1) {
    rowsFloat(job, out, w, h, y0, y1);
}

template <class T>
std::vector<Octave<T>> buildOctaves(const FractalParams& prm, int width) {
    std::vector<Octave<T>> octs(static_cast<std::size_t>(prm.octaves));
    double f = prm.frequency, a = 1.0;
    for (Octave<T>& o : octs) {
        o.f = f;
        o.a = a;
        o.period = prm.tileable ? (f > 256 ? 256 : static_cast<int>(f)) : 256;
        o.xf.resize(static_cast<std::size_t>(width));
        o.xf1.resize(o.xf.size());
        o.u.resize(o.xf.size());
        int prevX0 = -1, prevX1 = -1;
        double prevFloor = std::nan("");
        for (int c = 0; c < width; ++c) {
            const double x = f * (static_cast<double>(c) / width);
            const double fx = std::floor(x);
            const double xf = x - fx;
            o.xf[c] = static_cast<T>(xf);
            o.xf1[c] = static_cast<T>(xf - 1);
            o.u[c] = static_cast<T>(fade(xf));
            int X0, X1;
            if (o.period == 256) {
                X0 = floorToInt(x) & 255;
                X1 = X0 + 1;
            } else {
                X0 = wrapIndex(floorToInt(std::fmod(fx, o.period)), o.period);
                X1 = (X0 + 1) % o.period;
            }
            if (fx != prevFloor || X0 != prevX0 || X1 != prevX1) {
                o.spans.push_back({c, c + 1, X0, X1});
                prevFloor = fx;
                prevX0 = X0;
                prevX1 = X1;
            } else {
                o.spans.back().end = c + 1;
            }
        }
        f *= prm.lacunarity;
        a *= prm.gain;
    }
    return octs;
}

template <class T>
void fillImpl(const FractalParams& prm, std::span<T> out, int width, int height, const FillOptions& opt) {
    validate(prm);
    if (width < 1 || height < 1) throw InputError("size", "", "width and height must be at least 1");
    if (out.size() < static_cast<std::size_t>(width) * static_cast<std::size_t>(height))
        throw InputError("output buffer", "", "smaller than width x height");
    const Permutation perm = Permutation::fromSeed(prm.seed);
    std::vector<Octave<T>> octs = buildOctaves<T>(prm, width);
    if constexpr (std::is_same_v<T, float>)
        for (Octave<float>& o : octs) buildCornerTables(o, perm.table().data(), height, prm.z);
    const RowJob<T> job{&octs, perm.table().data(), prm.z, prm.turbulence};
    T* data = out.data();

    const int threads = resolveThreads(opt.threads);
    if (threads == 1) {
        rows(job, data, width, height, 0, height);
        return;
    }
    // Rows are independent, so any split gives the same bytes.
    tbb::task_arena arena(threads);
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<int>(0, height, 8), [&](const tbb::blocked_range<int>& r) {
            rows(job, data, width, height, r.begin(), r.end());
        });
    });
}

}  // namespace

void fillFractal(const FractalParams& p, std::span<double> out, int width, int height, const FillOptions& o) {
    fillImpl(p, out, width, height, o);
}

void fillFractal(const FractalParams& p, std::span<float> out, int width, int height, const FillOptions& o) {
    fillImpl(p, out, width, height, o);
}

std::string fastPathIsa() {
    if (floatIsa() == FloatIsa::V4) return "avx512f";
    if (floatIsa() == FloatIsa::V3) return "avx2";
    if (__builtin_cpu_supports("avx512f")) return "avx512f";
    if (__builtin_cpu_supports("avx2")) return "avx2";
    return "default";
}

}  // namespace mucosa::noise
