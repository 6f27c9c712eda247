#include <mucosa/mesh/tangents.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <vector>

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

// The sign of a triangle's UV area: +1 where (u, v) keep its winding, -1
// where they mirror it, 0 where the UV area is zero.
int uvOrientation(const Vec2& w0, const Vec2& w1, const Vec2& w2) noexcept {
    const float s1 = w1[0] - w0[0], t1 = w1[1] - w0[1];
    const float s2 = w2[0] - w0[0], t2 = w2[1] - w0[1];
    const float det = s1 * t2 - s2 * t1;
    const float scale = std::max(std::max(std::abs(s1), std::abs(t1)), std::max(std::abs(s2), std::abs(t2)));
    if (!(std::abs(det) > kMinRelativeUvDet * scale * scale) || !std::isfinite(det)) return 0;
    return det > 0 ? 1 : -1;
}

std::uint32_t findRoot(std::vector<std::uint32_t>& parent, std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
}

// MikkTSpace's groups (Mikkelsen 2008, Build4RuleGroups): around a vertex,
// the triangles with the same UV orientation that reach each other across
// edges they share form one group, and each group has its own frame (its
// handedness is the group's orientation). A vertex whose triangles form more
// than one group -- where the UVs fold over, or a mirrored chart meets an
// unmirrored one without a seam -- gets one copy per further group (all
// attributes copied), so per-vertex frames can be exact. Zero-UV-area
// triangles join the group of a neighbour (MikkTSpace's GROUP_WITH_ANY).
// Returns the number of vertices added.
std::size_t splitHandednessGroups(Mesh& mesh, const std::vector<int>& orient) {
    const std::size_t nv = mesh.vertexCount(), m = mesh.triangleCount();
    // Every used vertex is looked at: besides folds, a vertex where two fans
    // of one orientation touch without sharing an edge (a bow tie, as where
    // charts meet at a single vertex) also has two groups.
    std::vector<std::uint32_t> used;                  // the vertices a triangle uses
    std::vector<std::uint32_t> slot(nv, UINT32_MAX);  // vertex -> its slot in the corner table
    for (std::uint32_t i : mesh.indices)
        if (slot[i] == UINT32_MAX) slot[i] = static_cast<std::uint32_t>(used.size()), used.push_back(i);
    // The corners (3 t + j) at each vertex.
    std::vector<std::uint32_t> start(used.size() + 1, 0), corners;
    for (std::size_t c = 0; c < 3 * m; ++c)
        if (slot[mesh.indices[c]] != UINT32_MAX) ++start[slot[mesh.indices[c]] + 1];
    for (std::size_t i = 0; i < used.size(); ++i) start[i + 1] += start[i];
    corners.resize(start.back());
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t c = 0; c < 3 * m; ++c)
        if (slot[mesh.indices[c]] != UINT32_MAX) corners[fill[slot[mesh.indices[c]]]++] = static_cast<std::uint32_t>(c);

    const bool normals = mesh.hasNormals(), uvs = mesh.hasUvs(), colors = mesh.hasColors();
    std::size_t added = 0;
    std::vector<std::uint32_t> uf, copyOf;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;  // (other vertex, corner in the fan)
    std::vector<char> attached;
    for (std::size_t i = 0; i < used.size(); ++i) {
        const std::uint32_t v = used[i];
        const std::uint32_t* fan = corners.data() + start[i];
        const std::uint32_t k = start[i + 1] - start[i];
        // Fans joined across shared edges: each corner's two edges at v, by
        // the vertex at their other end, sorted; corners of one orientation
        // meeting on an edge unite (O(k log k), whatever the valence).
        edges.clear();
        for (std::uint32_t a = 0; a < k; ++a) {
            const std::size_t t = fan[a] / 3, j = fan[a] % 3;
            edges.emplace_back(mesh.indices[3 * t + (j + 1) % 3], a);
            edges.emplace_back(mesh.indices[3 * t + (j + 2) % 3], a);
        }
        std::sort(edges.begin(), edges.end());
        uf.resize(k);
        std::iota(uf.begin(), uf.end(), 0u);
        attached.assign(k, 0);
        for (std::size_t e = 0; e < edges.size();) {
            std::size_t f = e;
            while (f < edges.size() && edges[f].first == edges[e].first) ++f;
            std::uint32_t firstOriented = UINT32_MAX, firstOf[2] = {UINT32_MAX, UINT32_MAX};  // -1, +1
            for (std::size_t x = e; x < f; ++x) {
                const std::uint32_t a = edges[x].second;
                const int o = orient[fan[a] / 3];
                if (o == 0) continue;
                if (firstOriented == UINT32_MAX) firstOriented = a;
                std::uint32_t& first = firstOf[o > 0 ? 1 : 0];
                if (first == UINT32_MAX) {
                    first = a;
                } else {
                    const std::uint32_t ra = findRoot(uf, a), rb = findRoot(uf, first);
                    if (ra != rb) uf[std::max(ra, rb)] = std::min(ra, rb);
                }
            }
            // Zero-UV-area triangles: with the first oriented neighbour met.
            if (firstOriented != UINT32_MAX)
                for (std::size_t x = e; x < f; ++x) {
                    const std::uint32_t a = edges[x].second;
                    if (orient[fan[a] / 3] == 0 && !attached[a]) {
                        const std::uint32_t ra = findRoot(uf, a), rb = findRoot(uf, firstOriented);
                        if (ra != rb) uf[std::max(ra, rb)] = std::min(ra, rb);
                        attached[a] = 1;
                    }
                }
            e = f;
        }
        // The group of the first corner keeps v; each other group gets a copy.
        const std::uint32_t keep = findRoot(uf, 0);
        copyOf.assign(k, UINT32_MAX);  // group root -> its new vertex
        for (std::uint32_t a = 0; a < k; ++a) {
            const std::uint32_t g = findRoot(uf, a);
            if (g == keep) continue;
            if (copyOf[g] == UINT32_MAX) {
                copyOf[g] = static_cast<std::uint32_t>(mesh.positions.size());
                mesh.positions.push_back(mesh.positions[v]);
                if (normals) mesh.normals.push_back(mesh.normals[v]);
                if (uvs) mesh.uvs.push_back(mesh.uvs[v]);
                if (colors) mesh.colors.push_back(mesh.colors[v]);
                ++added;
            }
            mesh.indices[fan[a]] = copyOf[g];
        }
    }
    return added;
}

}  // namespace

TangentReport computeTangents(Mesh& mesh, int threads) {
    if (!mesh.hasNormals()) throw InputError("tangents", "", "the mesh has no normals");
    if (!mesh.hasUvs())
        throw InputError("tangents", "", "the mesh has no texture coordinates (generate them, e.g. --uv centerline)");
    validateIndices(mesh);
    requireMemory(saturatingMul(mesh.vertexCount(), sizeof(Vec4) + 2 * sizeof(Vec3) + 2 * sizeof(int)),
                  "tangent frames");
    TangentReport rep;
    const std::size_t m = mesh.triangleCount();
    std::vector<int> orient(m);
    for (std::size_t t = 0; t < m; ++t) {
        const std::uint32_t* i = &mesh.indices[3 * t];
        orient[t] = uvOrientation(mesh.uvs[i[0]], mesh.uvs[i[1]], mesh.uvs[i[2]]);
    }
    mesh.tangents.clear();
    rep.splitVertices = splitHandednessGroups(mesh, orient);
    const std::size_t n = mesh.vertexCount();

    const auto* P = mesh.positions.data();
    const auto* Nv = mesh.normals.data();
    const auto* uv = mesh.uvs.data();
    const auto* idx = mesh.indices.data();

    // Scatter: one pass over the triangles adds each corner's contribution to
    // its vertex. Serial on purpose: the sums then run in one fixed order (the
    // result never depends on the thread count), and a single streaming pass
    // with three writes per triangle beats a gather through a vertex ->
    // triangle table (three times the random reads) even on several cores.
    std::vector<Vec3> Tsum(n, Vec3{0, 0, 0}), Bsum(n, Vec3{0, 0, 0});
    std::vector<int> orientSum(n, 0);  // the vertex's group orientation (all its triangles agree after the split)
    for (std::size_t t = 0; t < m; ++t) {
        const std::uint32_t i[3] = {idx[3 * t], idx[3 * t + 1], idx[3 * t + 2]};
        const TriangleFrame f = triangleFrame(P[i[0]], P[i[1]], P[i[2]], uv[i[0]], uv[i[1]], uv[i[2]]);
        if (!f.valid) {
            ++rep.degenerateUvTriangles;
            continue;
        }
        for (int j = 0; j < 3; ++j) {
            orientSum[i[j]] += orient[t];
            // The corner angle between the two edges leaving corner j, both
            // projected on the vertex's tangent plane (as MikkTSpace weighs).
            const Vec3& N = Nv[i[j]];
            const Vec3 a = P[i[(j + 1) % 3]] - P[i[j]], b = P[i[(j + 2) % 3]] - P[i[j]];
            const Vec3 ap = normalizeOr(a - N * dot(N, a), Vec3{0, 0, 0});
            const Vec3 bp = normalizeOr(b - N * dot(N, b), Vec3{0, 0, 0});
            const float angle = fastAcos(std::clamp(dot(ap, bp), -1.0f, 1.0f));
            if (!(angle > 0.0f)) continue;
            // Projection on the vertex's tangent plane, normalised, weighted by
            // the corner angle (Mikkelsen 2008, MikkTSpace), then summed.
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
                    // Handedness: the group's UV orientation (MikkTSpace);
                    // w = sign(dot(cross(N, T), B)) (Lengyel 2001) if none.
                    w = orientSum[v] != 0 ? (orientSum[v] < 0 ? -1.0f : 1.0f)
                                          : (dot(cross(N, T), Bsum[v]) < 0.0f ? -1.0f : 1.0f);
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
