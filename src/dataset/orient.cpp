#include <mucosa/dataset/orient.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numbers>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/parallel.hpp>

namespace mucosa::dataset {

namespace {

using frames::Vec3d;

Vec3d toD(const mesh::Vec3& v) {
    return {double(v[0]), double(v[1]), double(v[2])};
}

Vec3d faceNormal(const mesh::Mesh& m, std::size_t t) {
    const Vec3d a = toD(m.positions[m.indices[3 * t]]), b = toD(m.positions[m.indices[3 * t + 1]]),
                c = toD(m.positions[m.indices[3 * t + 2]]);
    const Vec3d e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    return {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
}

double dot(const Vec3d& a, const Vec3d& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// kLumenRayDirections unit vectors spread evenly over the sphere (the
// Fibonacci lattice: z uniform in (-1, 1), longitude by the golden angle).
std::vector<Vec3d> sphereDirections() {
    std::vector<Vec3d> d;
    const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
    for (int i = 0; i < kLumenRayDirections; ++i) {
        const double z = 1.0 - (2.0 * i + 1.0) / kLumenRayDirections;
        const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        d.push_back({r * std::cos(golden * i), r * std::sin(golden * i), z});
    }
    return d;
}

// The points of the centerline's longest tree (the branches under one root,
// by their summed length): the airway's. A separate piece of the mesh -- the
// CT file's closed carina body -- has a level-set centerline of its own,
// inside it, from where it would be seen from behind; it is looked at from
// the airway instead.
std::vector<Vec3d> centerlinePoints(const mesh::Centerline& c) {
    const std::size_t n = c.branches.size();
    std::vector<std::size_t> root(n);
    std::vector<double> treeLength(n, 0.0);
    for (std::size_t b = 0; b < n; ++b) {
        const int parent = c.branches[b].parent;
        root[b] = parent >= 0 && std::size_t(parent) < b ? root[std::size_t(parent)] : b;
        const auto& pts = c.branches[b].points;
        for (std::size_t i = 1; i < pts.size(); ++i) {
            const Vec3d d{double(pts[i][0]) - pts[i - 1][0], double(pts[i][1]) - pts[i - 1][1],
                          double(pts[i][2]) - pts[i - 1][2]};
            const double l = std::sqrt(dot(d, d));
            if (std::isfinite(l)) treeLength[root[b]] += l;
        }
    }
    std::size_t best = 0;
    for (std::size_t b = 0; b < n; ++b)
        if (treeLength[b] > treeLength[best]) best = b;
    std::vector<Vec3d> p;
    for (std::size_t b = 0; b < n; ++b)
        if (root[b] == best)
            for (const mesh::Vec3& q : c.branches[b].points)
                if (std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2])) p.push_back(toD(q));
    return p;
}

// Per ray (point-major), the triangle it meets first (-1: none) and whether
// it sees that triangle's front.
struct Hits {
    std::vector<std::int32_t> triangle;
    std::vector<std::uint8_t> front;
};

Hits castFromCenterline(const RayCaster& caster, const std::vector<Vec3d>& points, int threads) {
    const std::vector<Vec3d> dirs = sphereDirections();
    Hits h;
    h.triangle.assign(points.size() * dirs.size(), -1);
    h.front.assign(h.triangle.size(), 0);
    tbb::task_arena arena(resolveThreads(threads));
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size()), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i)
                for (std::size_t k = 0; k < dirs.size(); ++k) {
                    const auto hit = caster.firstHit(points[i], dirs[k]);
                    if (!hit) continue;
                    const std::size_t ray = i * dirs.size() + k;
                    h.triangle[ray] = hit->triangle;
                    h.front[ray] = dot(faceNormal(caster.mesh(), std::size_t(hit->triangle)), dirs[k]) < 0 ? 1 : 0;
                }
        });
    });
    return h;
}

LumenView summarise(const Hits& h) {
    LumenView v;
    v.rays = h.triangle.size();
    for (std::size_t i = 0; i < h.triangle.size(); ++i)
        if (h.triangle[i] >= 0) ++v.hits, v.front += h.front[i];
    return v;
}

std::uint32_t findRoot(std::vector<std::uint32_t>& parent, std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
}

// Patches: triangles joined across every edge that exactly two triangles
// share, traversing it in opposite directions (a consistently wound
// manifold edge). Positions are welded exactly (split UV seams join).
std::vector<std::uint32_t> patchesOf(const mesh::Mesh& m) {
    const std::size_t nt = m.triangleCount();
    // Exact welding by sorting the positions' bit patterns.
    std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint32_t>> keyed(m.vertexCount());
    for (std::size_t v = 0; v < m.vertexCount(); ++v) {
        std::memcpy(keyed[v].first.data(), m.positions[v].data(), sizeof(mesh::Vec3));
        keyed[v].second = static_cast<std::uint32_t>(v);
    }
    std::sort(keyed.begin(), keyed.end());
    std::vector<std::uint32_t> id(m.vertexCount());
    std::uint32_t next = 0;
    for (std::size_t i = 0; i < keyed.size(); ++i) {
        if (i > 0 && keyed[i].first != keyed[i - 1].first) ++next;
        id[keyed[i].second] = next;
    }
    struct Use {
        std::uint64_t edge;  // (low id, high id)
        std::uint32_t triangle;
        bool forward;  // traversed low -> high
    };
    std::vector<Use> uses;
    uses.reserve(3 * nt);
    for (std::size_t t = 0; t < nt; ++t)
        for (int j = 0; j < 3; ++j) {
            const std::uint32_t a = id[m.indices[3 * t + std::size_t(j)]],
                                b = id[m.indices[3 * t + std::size_t((j + 1) % 3)]];
            if (a == b) continue;
            uses.push_back({(std::uint64_t(std::min(a, b)) << 32) | std::max(a, b), std::uint32_t(t), a < b});
        }
    std::sort(uses.begin(), uses.end(),
              [](const Use& x, const Use& y) { return x.edge != y.edge ? x.edge < y.edge : x.triangle < y.triangle; });
    std::vector<std::uint32_t> parent(nt);
    std::iota(parent.begin(), parent.end(), 0u);
    for (std::size_t i = 0; i < uses.size();) {
        std::size_t j = i;
        while (j < uses.size() && uses[j].edge == uses[i].edge) ++j;
        if (j - i == 2 && uses[i].forward != uses[i + 1].forward) {
            const std::uint32_t a = findRoot(parent, uses[i].triangle), b = findRoot(parent, uses[i + 1].triangle);
            if (a != b) parent[std::max(a, b)] = std::min(a, b);
        }
        i = j;
    }
    for (std::uint32_t t = 0; t < nt; ++t) parent[t] = findRoot(parent, t);
    return parent;
}

}  // namespace

LumenView viewFromCenterline(const RayCaster& caster, const mesh::Centerline& centerline, int threads) {
    const std::vector<Vec3d> points = centerlinePoints(centerline);
    if (points.empty()) throw InputError("centerline", "", "has no points to look from");
    return summarise(castFromCenterline(caster, points, threads));
}

LumenOrientReport orientToLumen(mesh::Mesh& m, const mesh::Centerline& centerline, int threads) {
    const std::vector<Vec3d> points = centerlinePoints(centerline);
    if (points.empty()) throw InputError("centerline", "", "has no points to look from");
    LumenOrientReport rep;
    Hits hits;
    {
        const RayCaster caster(m);
        hits = castFromCenterline(caster, points, threads);
    }
    rep.before = summarise(hits);
    const std::vector<std::uint32_t> patch = patchesOf(m);
    const std::size_t nt = m.triangleCount();
    // Votes per patch: + for a hit on its front, - on its back.
    std::vector<std::int64_t> votes(nt, 0);
    std::vector<char> isPatch(nt, 0), seen(nt, 0);
    for (std::size_t t = 0; t < nt; ++t) isPatch[patch[t]] = 1;
    for (std::size_t i = 0; i < hits.triangle.size(); ++i)
        if (hits.triangle[i] >= 0) {
            const std::uint32_t p = patch[std::size_t(hits.triangle[i])];
            votes[p] += hits.front[i] ? 1 : -1;
            seen[p] = 1;
        }
    std::vector<char> turn(nt, 0);
    for (std::size_t p = 0; p < nt; ++p) {
        if (!isPatch[p]) continue;
        ++rep.patches;
        if (!seen[p]) ++rep.unseenPatches;
        if (votes[p] < 0) turn[p] = 1, ++rep.turnedPatches;
    }
    for (std::size_t t = 0; t < nt; ++t)
        if (turn[patch[t]]) {
            std::swap(m.indices[3 * t + 1], m.indices[3 * t + 2]);
            ++rep.turnedTriangles;
        }
    rep.after = rep.before;
    rep.after.front = 0;
    for (std::size_t i = 0; i < hits.triangle.size(); ++i)
        if (hits.triangle[i] >= 0)
            rep.after.front += (hits.front[i] != 0) != (turn[patch[std::size_t(hits.triangle[i])]] != 0);
    // Normals with the winding: each against the triangles around it turns.
    if (m.hasNormals()) {
        std::vector<Vec3d> around(m.vertexCount(), Vec3d{0, 0, 0});
        for (std::size_t t = 0; t < nt; ++t) {
            const Vec3d n = faceNormal(m, t);
            for (int j = 0; j < 3; ++j) {
                Vec3d& a = around[m.indices[3 * t + std::size_t(j)]];
                for (int k = 0; k < 3; ++k) a[std::size_t(k)] += n[std::size_t(k)];
            }
        }
        for (std::size_t v = 0; v < m.vertexCount(); ++v)
            if (dot(toD(m.normals[v]), around[v]) < 0) {
                for (float& c : m.normals[v]) c = -c;
                ++rep.normalsTurned;
            }
    }
    m.tangents.clear();
    return rep;
}

BackFaceView backFacesSeen(const GroundTruth& truth, const mesh::Mesh& m, const Vec3d& eye, float litSide) {
    BackFaceView v;
    const std::size_t n = truth.face.size();
    for (std::size_t p = 0; p < n; ++p) {
        if (!truth.valid[p] || (!truth.inView.empty() && !truth.inView[p]) || truth.face[p] < 0) continue;
        const std::size_t t = std::size_t(truth.face[p]);
        if (t >= m.triangleCount()) continue;
        const double b1 = truth.b1[p], b2 = truth.b2[p], b0 = 1.0 - b1 - b2;
        Vec3d at{0, 0, 0};
        for (int k = 0; k < 3; ++k)
            at[std::size_t(k)] = b0 * m.positions[m.indices[3 * t]][std::size_t(k)] +
                                 b1 * m.positions[m.indices[3 * t + 1]][std::size_t(k)] +
                                 b2 * m.positions[m.indices[3 * t + 2]][std::size_t(k)] - eye[std::size_t(k)];
        ++v.seen;
        v.back += dot(faceNormal(m, t), at) * double(litSide) > 0 ? 1 : 0;
    }
    return v;
}

}  // namespace mucosa::dataset
