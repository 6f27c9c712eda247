#include <mucosa/mesh/tangents.hpp>

#include <atomic>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/core/parallel.hpp>
#include <mucosa/mesh/io.hpp>

#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;

namespace {

// Per-triangle T and B directions (Lengyel 2001, eq. 5 of the paper):
// [T; B] = 1/(s1 t2 - s2 t1) [[t2, -t1], [-s2, s1]] [Q1; Q2].
// Only directions matter (they are normalised per corner), so the 1/det factor
// reduces to its sign; |det| below kMinUvDet of the UV scale marks a triangle
// whose UV area is zero: it says nothing about dP/du and contributes nothing.
constexpr float kMinRelativeUvDet = 1e-12f;

struct TriangleFrame {
    Vec3 T, B;
    bool valid;
};

inline TriangleFrame triangleFrame(const Vec3& P0, const Vec3& P1, const Vec3& P2, const Vec2& w0, const Vec2& w1,
                                   const Vec2& w2) noexcept {
    const Vec3 Q1 = P1 - P0, Q2 = P2 - P0;
    const float s1 = w1[0] - w0[0], t1 = w1[1] - w0[1];
    const float s2 = w2[0] - w0[0], t2 = w2[1] - w0[1];
    const float det = s1 * t2 - s2 * t1;
    const float scale = std::max(std::max(std::abs(s1), std::abs(t1)), std::max(std::abs(s2), std::abs(t2)));
    if (!(std::abs(det) > kMinRelativeUvDet * scale * scale) || !std::isfinite(det)) return {{}, {}, false};
    const float r = det > 0 ? 1.0f : -1.0f;
    return {(t2 * Q1 - t1 * Q2) * r, (s1 * Q2 - s2 * Q1) * r, true};
}

// acos(x) to within 7e-5 rad (Abramowitz & Stegun 1964, eq. 4.4.45):
// acos(x) = sqrt(1 - x) (a0 + a1 x + a2 x^2 + a3 x^3) for 0 <= x <= 1, and
// pi - acos(-x) below 0. Plenty for weights; several times cheaper than atan2.
inline float fastAcos(float x) noexcept {
    const float ax = std::min(std::abs(x), 1.0f);
    const float r = std::sqrt(1.0f - ax) * (1.5707288f + ax * (-0.2121144f + ax * (0.0742610f - 0.0187293f * ax)));
    return x >= 0.0f ? r : 3.14159265f - r;
}

}  // namespace

TangentReport computeTangents(Mesh& mesh, int threads) {
    if (!mesh.hasNormals()) throw InputError("tangents", "", "the mesh has no normals");
    if (!mesh.hasUvs())
        throw InputError("tangents", "", "the mesh has no texture coordinates (generate them, e.g. --uv centerline)");
    validateIndices(mesh);
    const std::size_t n = mesh.vertexCount();
    requireMemory(saturatingMul(n, sizeof(Vec4) + 2 * sizeof(Vec3)), "tangent frames");

    const auto* P = mesh.positions.data();
    const auto* Nv = mesh.normals.data();
    const auto* uv = mesh.uvs.data();
    const auto* idx = mesh.indices.data();
    TangentReport rep;

    // Scatter: one pass over the triangles adds each corner's contribution to
    // its vertex. Serial on purpose: the sums then run in one fixed order (the
    // result never depends on the thread count), and a single streaming pass
    // with three writes per triangle beats a gather through a vertex ->
    // triangle table (three times the random reads) even on several cores.
    std::vector<Vec3> Tsum(n, Vec3{0, 0, 0}), Bsum(n, Vec3{0, 0, 0});
    const std::size_t m = mesh.triangleCount();
    for (std::size_t t = 0; t < m; ++t) {
        const std::uint32_t i[3] = {idx[3 * t], idx[3 * t + 1], idx[3 * t + 2]};
        const TriangleFrame f = triangleFrame(P[i[0]], P[i[1]], P[i[2]], uv[i[0]], uv[i[1]], uv[i[2]]);
        if (!f.valid) {
            ++rep.degenerateUvTriangles;
            continue;
        }
        const Vec3 e[3] = {P[i[1]] - P[i[0]], P[i[2]] - P[i[1]], P[i[0]] - P[i[2]]};
        float inv[3];
        for (int j = 0; j < 3; ++j) {
            const float l2 = dot(e[j], e[j]);
            inv[j] = l2 > 0.0f ? 1.0f / std::sqrt(l2) : 0.0f;
        }
        for (int j = 0; j < 3; ++j) {
            // Corner angle between the two edges leaving corner j: e[j] and -e[j-1].
            const int k = (j + 2) % 3;
            if (inv[j] == 0.0f || inv[k] == 0.0f) continue;
            const float angle = fastAcos(-dot(e[j], e[k]) * inv[j] * inv[k]);
            if (!(angle > 0.0f)) continue;
            // Projection on the vertex's tangent plane, normalised, weighted by
            // the corner angle (Mikkelsen 2008, MikkTSpace), then summed.
            const Vec3& N = Nv[i[j]];
            const Vec3 Tp = normalizeOr(f.T - N * dot(N, f.T), Vec3{0, 0, 0});
            const Vec3 Bp = normalizeOr(f.B - N * dot(N, f.B), Vec3{0, 0, 0});
            Tsum[i[j]] += Tp * angle;
            Bsum[i[j]] += Bp * angle;
        }
    }

    mesh.tangents.resize(n);
    auto* out = mesh.tangents.data();
    std::atomic<std::size_t> fallback{0}, mirrored{0};
    tbb::task_arena arena(resolveThreads(threads));
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 8192), [&](const tbb::blocked_range<std::size_t>& r) {
            std::size_t localFallback = 0, localMirrored = 0;
            for (std::size_t v = r.begin(); v != r.end(); ++v) {
                const Vec3 N = normalizeOr(Nv[v], Vec3{0, 0, 1});
                // Gram-Schmidt: T = normalize(T - N (N.T)) (Lengyel 2001).
                Vec3 T = Tsum[v] - N * dot(N, Tsum[v]);
                const float Tlen = length(T);
                const float Blen = length(Bsum[v] - N * dot(N, Bsum[v]));
                float w = 1.0f;
                if (Tlen > 1e-6f * (Blen + 1e-30f) && Tlen > 1e-30f && std::isfinite(Tlen)) {
                    T = T * (1.0f / Tlen);
                    // Handedness: w = sign(dot(cross(N, T), B)) (Lengyel 2001).
                    w = dot(cross(N, T), Bsum[v]) < 0.0f ? -1.0f : 1.0f;
                } else if (Blen > 1e-30f && std::isfinite(Blen)) {
                    // Only dP/dv is known: T = B x N so that B = cross(N, T), w = +1.
                    T = normalizeOr(cross(Bsum[v], N), anyPerpendicular(N));
                    ++localFallback;
                } else {
                    T = anyPerpendicular(N);
                    ++localFallback;
                }
                if (w < 0) ++localMirrored;
                out[v] = {T[0], T[1], T[2], w};
            }
            fallback += localFallback;
            mirrored += localMirrored;
        });
    });
    rep.fallbackVertices = fallback;
    rep.mirroredVertices = mirrored;
    return rep;
}

Vec4 fallbackTangent(const Vec3& n) noexcept {
    const float sign = std::copysign(1.0f, n[2]);
    const float a = -1.0f / (sign + n[2]);
    const float b = n[0] * n[1] * a;
    return {1.0f + sign * n[0] * n[0] * a, sign * b, -sign * n[0], 1.0f};
}

}  // namespace mucosa::mesh
