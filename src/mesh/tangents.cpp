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

#include "adjacency.hpp"
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

}  // namespace

TangentReport computeTangents(Mesh& mesh, int threads) {
    if (!mesh.hasNormals()) throw InputError("tangents", "", "the mesh has no normals");
    if (!mesh.hasUvs())
        throw InputError("tangents", "", "the mesh has no texture coordinates (generate them, e.g. --uv centerline)");
    validateIndices(mesh);
    const std::size_t n = mesh.vertexCount();
    requireMemory(saturatingMul(n, sizeof(Vec4) + 4) + saturatingMul(mesh.indices.size(), 8), "tangent frames");

    const VertexCorners vc = vertexCorners(mesh);
    mesh.tangents.assign(n, Vec4{1, 0, 0, 1});

    std::atomic<std::size_t> fallback{0}, mirrored{0};
    const auto* P = mesh.positions.data();
    const auto* Nv = mesh.normals.data();
    const auto* uv = mesh.uvs.data();
    const auto* idx = mesh.indices.data();
    auto* out = mesh.tangents.data();

    tbb::task_arena arena(resolveThreads(threads));
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
            std::size_t localFallback = 0, localMirrored = 0;
            for (std::size_t v = r.begin(); v != r.end(); ++v) {
                Vec3 N = Nv[v];
                N = normalizeOr(N, Vec3{0, 0, 1});
                Vec3 Tsum{0, 0, 0}, Bsum{0, 0, 0};
                for (std::uint32_t k = vc.offsets[v]; k < vc.offsets[v + 1]; ++k) {
                    const std::uint32_t c = vc.corners[k], t = c - c % 3, j = c % 3;
                    const std::uint32_t i0 = idx[t + j], i1 = idx[t + (j + 1) % 3], i2 = idx[t + (j + 2) % 3];
                    const TriangleFrame f = triangleFrame(P[i0], P[i1], P[i2], uv[i0], uv[i1], uv[i2]);
                    if (!f.valid) continue;
                    // Corner angle weight and projection on this vertex's tangent
                    // plane before summing (Mikkelsen 2008, MikkTSpace).
                    const float angle = cornerAngle(P[i0], P[i1], P[i2]);
                    if (!(angle > 0.0f)) continue;
                    const Vec3 Tp = normalizeOr(f.T - N * dot(N, f.T), Vec3{0, 0, 0});
                    const Vec3 Bp = normalizeOr(f.B - N * dot(N, f.B), Vec3{0, 0, 0});
                    Tsum += Tp * angle;
                    Bsum += Bp * angle;
                }
                // Gram-Schmidt: T = normalize(T - N (N.T)) (Lengyel 2001).
                Vec3 T = Tsum - N * dot(N, Tsum);
                const float Tlen = length(T);
                const float Blen = length(Bsum - N * dot(N, Bsum));
                float w = 1.0f;
                if (Tlen > 1e-6f * (Blen + 1e-30f) && Tlen > 1e-30f && std::isfinite(Tlen)) {
                    T = T * (1.0f / Tlen);
                    // Handedness: w = sign(dot(cross(N, T), B)) (Lengyel 2001).
                    w = dot(cross(N, T), Bsum) < 0.0f ? -1.0f : 1.0f;
                } else if (Blen > 1e-30f && std::isfinite(Blen)) {
                    // Only dP/dv is known: T = B x N so that B = cross(N, T), w = +1.
                    T = normalizeOr(cross(Bsum, N), anyPerpendicular(N));
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

    TangentReport rep;
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        const std::uint32_t i0 = idx[t], i1 = idx[t + 1], i2 = idx[t + 2];
        if (!triangleFrame(P[i0], P[i1], P[i2], uv[i0], uv[i1], uv[i2]).valid) ++rep.degenerateUvTriangles;
    }
    rep.fallbackVertices = fallback;
    rep.mirroredVertices = mirrored;
    return rep;
}

}  // namespace mucosa::mesh
