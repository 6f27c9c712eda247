#include <mucosa/mesh/analysis.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include <mucosa/mesh/io.hpp>

#include "adjacency.hpp"
#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;

namespace {

std::uint32_t findRoot(std::vector<std::uint32_t>& parent, std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
}

}  // namespace

MeshReport analyze(const Mesh& mesh) {
    validateIndices(mesh);
    MeshReport r;
    r.vertices = mesh.vertexCount();
    r.triangles = mesh.triangleCount();
    r.hasNormals = mesh.hasNormals();
    r.hasUvs = mesh.hasUvs();
    r.hasTangents = mesh.hasTangents();

    auto countNonFinite = [&](const auto& arr) {
        for (const auto& a : arr)
            for (float c : a) r.nonFiniteValues += std::isfinite(c) ? 0 : 1;
    };
    countNonFinite(mesh.positions);
    countNonFinite(mesh.normals);
    countNonFinite(mesh.uvs);
    countNonFinite(mesh.tangents);

    Vec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (const Vec3& p : mesh.positions)
        if (finite(p))
            for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    r.boundsMin = lo;
    r.boundsMax = hi;

    std::vector<std::uint32_t> ids;
    r.uniquePositions = positionIds(mesh, ids);
    // Boundary edges in the direction their triangle traverses them.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> boundary;
    for (const EdgeUse& e : edgeUses(mesh, ids)) {
        if (e.count == 1) ++r.boundaryEdges, boundary.emplace_back(e.forward ? e.a : e.b, e.forward ? e.b : e.a);
        if (e.count > 2) ++r.nonManifoldEdges;
        if (e.count == 2 && e.forward != 1) ++r.inconsistentEdges;
    }

    // Components through shared positions (union-find).
    std::vector<std::uint32_t> parent(mesh.vertexCount());
    std::iota(parent.begin(), parent.end(), 0u);
    std::vector<char> used(mesh.vertexCount(), 0);
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        const std::uint32_t a = findRoot(parent, ids[mesh.indices[t]]);
        for (int k = 0; k < 3; ++k) used[mesh.indices[t + k]] = 1;
        for (int k = 1; k < 3; ++k) {
            const std::uint32_t b = findRoot(parent, ids[mesh.indices[t + k]]);
            if (a != b) parent[b] = a;
        }
    }
    for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
        if (!used[v])
            ++r.unusedVertices;
        else if (ids[v] == v && findRoot(parent, static_cast<std::uint32_t>(v)) == v)
            ++r.components;
    }

    // Area, signed volume (divergence theorem: V = 1/6 sum P0 . (P1 x P2)),
    // degenerate triangles, and normals against the winding.
    // Normals against the winding of all the triangles at their position
    // with that normal: UV seams and tangent splits copy vertices (a copy
    // used by one sliver does not speak for the surface there), creases split
    // them with other normals (each side speaks for itself).
    std::vector<Vec3d> windingNormal(r.hasNormals ? mesh.vertexCount() : 0, Vec3d{0, 0, 0});
    std::vector<std::uint32_t> normalGroup(r.hasNormals ? mesh.vertexCount() : 0);
    if (r.hasNormals) {
        std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> byPosition;  // position id -> vertices
        for (std::uint32_t v = 0; v < mesh.vertexCount(); ++v) {
            normalGroup[v] = v;
            auto& list = byPosition[ids[v]];
            for (std::uint32_t w : list)
                if (mesh.normals[w] == mesh.normals[v]) {
                    normalGroup[v] = w;
                    break;
                }
            if (normalGroup[v] == v) list.push_back(v);
        }
    }
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        const std::uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
        const Vec3d p0 = toD(mesh.positions[a]), p1 = toD(mesh.positions[b]), p2 = toD(mesh.positions[c]);
        const Vec3d n = cross(p1 - p0, p2 - p0);
        const double area2 = length(n);
        const double scale = std::max(dot(p1 - p0, p1 - p0), dot(p2 - p0, p2 - p0));
        if (a == b || b == c || a == c || !(area2 > 1e-12 * scale)) ++r.degenerateTriangles;
        if (std::isfinite(area2)) {
            r.surfaceArea += 0.5 * area2;
            r.signedVolume += dot(p0, cross(p1, p2)) / 6.0;
        }
        if (r.hasNormals && std::isfinite(area2))
            for (std::uint32_t v : {a, b, c}) windingNormal[normalGroup[v]] += n;
    }
    // An open surface (a CT airway with cut ends) encloses nothing: close
    // each boundary loop with a fan to its centroid, so that the sign says
    // which way the winding faces (the missing caps of a tube far from the
    // origin otherwise dominate the sum and can flip its sign).
    if (!boundary.empty()) {
        std::unordered_map<std::uint32_t, std::uint32_t> next;
        for (const auto& [from, to] : boundary) next.emplace(from, to);
        std::unordered_map<std::uint32_t, char> done;
        for (const auto& [start, unused] : boundary) {
            if (done.count(start)) continue;
            std::vector<std::uint32_t> loop;
            for (std::uint32_t v = start; !done.count(v);) {
                done[v] = 1;
                loop.push_back(v);
                const auto it = next.find(v);
                if (it == next.end()) break;
                v = it->second;
            }
            Vec3d c{0, 0, 0};
            for (std::uint32_t v : loop) c += toD(mesh.positions[v]);
            c = c * (1.0 / static_cast<double>(loop.size()));
            for (std::uint32_t v : loop) {
                const auto it = next.find(v);
                if (it == next.end()) continue;
                // Cap triangle (to, from, c): the edge reversed, as its neighbour would use it.
                const Vec3d pf = toD(mesh.positions[v]), pt = toD(mesh.positions[it->second]);
                if (finite(mesh.positions[v]) && finite(mesh.positions[it->second]))
                    r.signedVolume += dot(pt, cross(pf, c)) / 6.0;
            }
            ++r.boundaryLoops;
        }
    }
    if (r.hasNormals) {
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            const Vec3& N = mesh.normals[v];
            const float len = length(N);
            if (!std::isfinite(len) || std::abs(len - 1.0f) > 1e-3f) ++r.badNormals;
            if (used[v] && dot(toD(N), windingNormal[normalGroup[v]]) < 0) ++r.normalsAgainstWinding;
        }
    }
    if (r.hasTangents && r.hasNormals) {
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            const Vec4& T = mesh.tangents[v];
            const Vec3 t{T[0], T[1], T[2]};
            const float len = length(t);
            if (!std::isfinite(len) || std::abs(len - 1.0f) > 1e-3f || std::abs(dot(t, mesh.normals[v])) > 1e-3f ||
                std::abs(T[3]) != 1.0f)
                ++r.badTangents;
        }
    }
    if (r.hasUvs && r.surfaceArea > 0 && r.nonFiniteValues == 0) r.stretch = measureUvStretch(mesh);
    return r;
}

}  // namespace mucosa::mesh
