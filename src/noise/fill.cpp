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
#include <thread>
#include <type_traits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/parallel.hpp>

#include "core/simd.hpp"

namespace mucosa::noise {

namespace {

struct Span {
    int begin, end;  // columns [begin, end) share lattice cell X0
    int X0, X1;
};

// Column data of one octave, shared by all rows.
template <class T>
struct Octave {
    double f = 0, a = 0;
    int period = 256;  // 256 = plain noise
    std::vector<T> xf, xf1, u;
    std::vector<Span> spans;
    // Float path: the corner gradients of every (lattice row Y0, span), so a
    // row needs no hashing (see buildCornerTables). Empty: hash per span.
    std::array<int, 256> ySlot{};
    std::vector<float> corners;  // [slot][kCornerFields][spans]
};

// Per corner pair k (l00, l10, l01, l11) of a span: gx of the a corner, gx(b) -
// gx(a), gy(a), gz(a), gx(b), gy(b) - gy(a), gz(b) - gz(a).
constexpr int kCornerFields = 28;

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
// the row's y, z weights W (v, w fixed per row and span), each x-lerp is
//   l = ga + u (gb - ga) = (sa x + Ca) + u ((sb - sa) x + (Cb - Ca)),
// so the octave's contribution a * n(x) = (P x + Q) + u (R x + S), four
// multiply-adds per sample. The algebra is exact; only float rounding differs
// from the reference, well inside the 1e-5 the tests hold it to.
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

template <bool kTurbulence>
__attribute__((always_inline)) inline void foldedKernel(float* __restrict acc, const float* __restrict xf,
                                                        const float* __restrict uu, int n, float P, float Q, float R,
                                                        float S) {
    for (int i = 0; i < n; ++i) {
        const float x = xf[i];
        const float val = (P * x + Q) + uu[i] * (R * x + S);
        acc[i] += kTurbulence ? std::fabs(val) : val;
    }
}

// Row frame of the float path: lattice indices and the four x-lerp weights.
struct FoldedFrame {
    int Y0, Y1, Z0, Z1;
    double W[4], yq[4], zq[4];
};

inline FoldedFrame foldedFrame(const Octave<float>& oct, double v, double z) {
    const RowFrame r = rowLattice(oct.f * v, z, oct.period);
    FoldedFrame fr{r.Y0, r.Y1, r.Z0, r.Z1, {}, {}, {}};
    const double vv = r.v, ww = r.w;
    const double W[4] = {(1 - vv) * (1 - ww) * oct.a, vv * (1 - ww) * oct.a, (1 - vv) * ww * oct.a, vv * ww * oct.a};
    const double yq[4] = {r.yf, r.yf - 1, r.yf, r.yf - 1}, zq[4] = {r.zf, r.zf, r.zf - 1, r.zf - 1};
    for (int k = 0; k < 4; ++k) {
        fr.W[k] = W[k];
        fr.yq[k] = yq[k];
        fr.zq[k] = zq[k];
    }
    return fr;
}

// Fills oct.corners for every lattice row the map's rows fall in (at most 256).
void buildCornerTables(Octave<float>& oct, const std::uint8_t* p, int height, double z) {
    constexpr std::size_t kMaxTableBytes = std::size_t{48} << 20;
    oct.ySlot.fill(-1);
    const std::size_t nsp = oct.spans.size();
    std::vector<FoldedFrame> rows;
    int slots = 0;
    for (int y = 0; y < height; ++y) {
        const FoldedFrame fr = foldedFrame(oct, static_cast<double>(y) / height, z);
        if (oct.ySlot[static_cast<std::size_t>(fr.Y0)] < 0) {
            oct.ySlot[static_cast<std::size_t>(fr.Y0)] = slots++;
            rows.push_back(fr);
        }
    }
    if (static_cast<std::size_t>(slots) * nsp * kCornerFields * sizeof(float) > kMaxTableBytes) {
        oct.ySlot.fill(-1);
        return;  // too many cells for a table: hash per span instead
    }
    oct.corners.assign(static_cast<std::size_t>(slots) * kCornerFields * nsp, 0.0f);
    for (int sl = 0; sl < slots; ++sl) {
        const FoldedFrame& fr = rows[static_cast<std::size_t>(sl)];
        const int Ys[4] = {fr.Y0, fr.Y1, fr.Y0, fr.Y1}, Zs[4] = {fr.Z0, fr.Z0, fr.Z1, fr.Z1};
        float* t = oct.corners.data() + static_cast<std::size_t>(sl) * kCornerFields * nsp;
        for (std::size_t j = 0; j < nsp; ++j) {
            const Span& sp = oct.spans[j];
            for (int k = 0; k < 4; ++k) {
                const int ha = p[p[p[sp.X0] + Ys[k]] + Zs[k]] & 15;
                const int hb = p[p[p[sp.X1] + Ys[k]] + Zs[k]] & 15;
                const float f[7] = {static_cast<float>(kGrad.gx[ha]),
                                    static_cast<float>(kGrad.gx[hb] - kGrad.gx[ha]),
                                    static_cast<float>(kGrad.gy[ha]),
                                    static_cast<float>(kGrad.gz[ha]),
                                    static_cast<float>(kGrad.gx[hb]),
                                    static_cast<float>(kGrad.gy[hb] - kGrad.gy[ha]),
                                    static_cast<float>(kGrad.gz[hb] - kGrad.gz[ha])};
                for (int q = 0; q < 7; ++q) t[static_cast<std::size_t>(7 * k + q) * nsp + j] = f[q];
            }
        }
    }
}

__attribute__((always_inline)) inline void rowBodyFolded(const RowJob<float>& job, float* row, int width, double v,
                                                         std::vector<float>& scratch) {
    std::fill(row, row + width, 0.0f);
    const std::uint8_t* p = job.p;
    for (const Octave<float>& oct : *job.octaves) {
        const FoldedFrame fr = foldedFrame(oct, v, job.z);
        const std::size_t nsp = oct.spans.size();
        const int slot = oct.ySlot[static_cast<std::size_t>(fr.Y0)];
        scratch.resize(4 * nsp);
        float* __restrict P = scratch.data();
        float* __restrict Q = P + nsp;
        float* __restrict R = Q + nsp;
        float* __restrict S = R + nsp;
        if (slot >= 0) {
            // P = sum W gx(a), R = sum W (gx(b) - gx(a)),
            // Q = sum W (gy(a) yq + gz(a) zq), S = sum W (-gx(b) + dgy yq + dgz zq),
            // for all spans at once (vectorised across spans).
            const float* t = oct.corners.data() + static_cast<std::size_t>(slot) * kCornerFields * nsp;
            std::fill(P, P + 4 * nsp, 0.0f);
            for (int k = 0; k < 4; ++k) {
                const float W = static_cast<float>(fr.W[k]);
                const float Wy = static_cast<float>(fr.W[k] * fr.yq[k]), Wz = static_cast<float>(fr.W[k] * fr.zq[k]);
                const float* gxa = t + static_cast<std::size_t>(7 * k) * nsp;
                const float* dgx = gxa + nsp;
                const float* gya = dgx + nsp;
                const float* gza = gya + nsp;
                const float* gxb = gza + nsp;
                const float* dgy = gxb + nsp;
                const float* dgz = dgy + nsp;
                for (std::size_t j = 0; j < nsp; ++j) {
                    P[j] += W * gxa[j];
                    R[j] += W * dgx[j];
                    Q[j] += Wy * gya[j] + Wz * gza[j];
                    S[j] += Wy * dgy[j] + Wz * dgz[j] - W * gxb[j];
                }
            }
        } else {
            const int Ys[4] = {fr.Y0, fr.Y1, fr.Y0, fr.Y1}, Zs[4] = {fr.Z0, fr.Z0, fr.Z1, fr.Z1};
            for (std::size_t j = 0; j < nsp; ++j) {
                const Span& sp = oct.spans[j];
                double p0 = 0, q0 = 0, r0 = 0, s0 = 0;
                for (int k = 0; k < 4; ++k) {
                    const int ha = p[p[p[sp.X0] + Ys[k]] + Zs[k]] & 15;
                    const int hb = p[p[p[sp.X1] + Ys[k]] + Zs[k]] & 15;
                    const double Ca = kGrad.gy[ha] * fr.yq[k] + kGrad.gz[ha] * fr.zq[k];
                    const double Cb = -kGrad.gx[hb] + kGrad.gy[hb] * fr.yq[k] + kGrad.gz[hb] * fr.zq[k];
                    p0 += fr.W[k] * kGrad.gx[ha];
                    q0 += fr.W[k] * Ca;
                    r0 += fr.W[k] * (kGrad.gx[hb] - kGrad.gx[ha]);
                    s0 += fr.W[k] * (Cb - Ca);
                }
                P[j] = static_cast<float>(p0);
                Q[j] = static_cast<float>(q0);
                R[j] = static_cast<float>(r0);
                S[j] = static_cast<float>(s0);
            }
        }
        for (std::size_t j = 0; j < nsp; ++j) {
            const Span& sp = oct.spans[j];
            const int n = sp.end - sp.begin;
            if (job.turbulence)
                foldedKernel<true>(row + sp.begin, oct.xf.data() + sp.begin, oct.u.data() + sp.begin, n, P[j], Q[j],
                                   R[j], S[j]);
            else
                foldedKernel<false>(row + sp.begin, oct.xf.data() + sp.begin, oct.u.data() + sp.begin, n, P[j], Q[j],
                                    R[j], S[j]);
        }
    }
}

// One clone per ISA; glibc's ifunc resolver picks the best at load time.
#define MUCOSA_CLONES MUCOSA_TARGET_CLONES

MUCOSA_CLONES void rowsDouble(const RowJob<double>& job, double* out, int width, int height, int y0, int y1) {
    for (int y = y0; y < y1; ++y)
        rowBody(job, out + static_cast<std::size_t>(y) * width, width, static_cast<double>(y) / height);
}

MUCOSA_CLONES void rowsFloat(const RowJob<float>& job, float* out, int width, int height, int y0, int y1) {
    std::vector<float> scratch;
    for (int y = y0; y < y1; ++y)
        rowBodyFolded(job, out + static_cast<std::size_t>(y) * width, width, static_cast<double>(y) / height, scratch);
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
    if (__builtin_cpu_supports("avx512f")) return "avx512f";
    if (__builtin_cpu_supports("avx2")) return "avx2";
    return "default";
}

}  // namespace mucosa::noise
