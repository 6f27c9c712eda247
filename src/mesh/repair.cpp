#include <mucosa/mesh/repair.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <unordered_map>

#include <mucosa/mesh/io.hpp>

#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;

namespace {

struct WeldKey {
    std::int64_t x, y, z;
    std::uint32_t u, v;
    std::uint32_t r, g, b;
    bool operator==(const WeldKey&) const = default;
};
struct WeldHash {
    std::size_t operator()(const WeldKey& k) const noexcept {
        std::uint64_t h = static_cast<std::uint64_t>(k.x) * 0x9E3779B97F4A7C15ull;
        h ^= static_cast<std::uint64_t>(k.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
        h ^= static_cast<std::uint64_t>(k.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
        h ^= (std::uint64_t{k.u} << 32 | k.v) * 0x27D4EB2F165667C5ull + (h << 6) + (h >> 2);
        h ^= (std::uint64_t{k.r} << 32 | k.g) * 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
        h ^= std::uint64_t{k.b} * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
        return static_cast<std::size_t>(h ^ (h >> 31));
    }
};

float canonical(float f) noexcept {
    return f == 0.0f ? 0.0f : f;
}

}  // namespace

std::size_t weld(Mesh& mesh, float tolerance) {
    validateIndices(mesh);
    const std::size_t n = mesh.vertexCount();
    const bool uvs = mesh.hasUvs(), normals = mesh.hasNormals(), colors = mesh.hasColors();
    // Positions snap to a grid of cell `tolerance` (exact match when 0): two
    // vertices weld when they fall in the same cell and share their UV (and
    // their colour: a tint edge stays sharp where the file has one).
    auto key = [&](std::size_t v) {
        WeldKey k{};
        const Vec3& p = mesh.positions[v];
        if (tolerance > 0) {
            k.x = static_cast<std::int64_t>(std::llround(p[0] / tolerance));
            k.y = static_cast<std::int64_t>(std::llround(p[1] / tolerance));
            k.z = static_cast<std::int64_t>(std::llround(p[2] / tolerance));
        } else {
            k.x = std::bit_cast<std::uint32_t>(canonical(p[0]));
            k.y = std::bit_cast<std::uint32_t>(canonical(p[1]));
            k.z = std::bit_cast<std::uint32_t>(canonical(p[2]));
        }
        if (uvs) {
            k.u = std::bit_cast<std::uint32_t>(canonical(mesh.uvs[v][0]));
            k.v = std::bit_cast<std::uint32_t>(canonical(mesh.uvs[v][1]));
        }
        if (colors) {
            k.r = std::bit_cast<std::uint32_t>(canonical(mesh.colors[v][0]));
            k.g = std::bit_cast<std::uint32_t>(canonical(mesh.colors[v][1]));
            k.b = std::bit_cast<std::uint32_t>(canonical(mesh.colors[v][2]));
        }
        return k;
    };
    std::unordered_map<WeldKey, std::uint32_t, WeldHash> first;
    first.reserve(n);
    std::vector<std::uint32_t> remap(n);
    Mesh out;
    std::vector<Vec3d> normalSum;
    for (std::size_t v = 0; v < n; ++v) {
        auto [it, inserted] = first.try_emplace(key(v), static_cast<std::uint32_t>(out.positions.size()));
        if (inserted) {
            out.positions.push_back(mesh.positions[v]);
            if (uvs) out.uvs.push_back(mesh.uvs[v]);
            if (colors) out.colors.push_back(mesh.colors[v]);
            if (normals) normalSum.push_back({0, 0, 0});
        }
        remap[v] = it->second;
        if (normals) normalSum[it->second] += toD(mesh.normals[v]);
    }
    const std::size_t removed = n - out.positions.size();
    if (normals) {
        out.normals.resize(normalSum.size());
        for (std::size_t v = 0; v < normalSum.size(); ++v)
            out.normals[v] = toF(normalizeOr(normalSum[v], Vec3d{0, 0, 1}));
    }
    out.indices.resize(mesh.indices.size());
    for (std::size_t i = 0; i < mesh.indices.size(); ++i) out.indices[i] = remap[mesh.indices[i]];
    if (removed == 0 && mesh.hasTangents()) out.tangents = std::move(mesh.tangents);  // nothing merged
    out.materials = std::move(mesh.materials);                                        // triangles stay in order
    mesh = std::move(out);
    return removed;
}

std::size_t removeDegenerateTriangles(Mesh& mesh) {
    validateIndices(mesh);
    std::size_t kept = 0;
    const std::size_t m = mesh.triangleCount();
    for (std::size_t t = 0; t < m; ++t) {
        const std::uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
        if (a == b || b == c || a == c) continue;
        const Vec3d p0 = toD(mesh.positions[a]), e1 = toD(mesh.positions[b]) - p0, e2 = toD(mesh.positions[c]) - p0;
        // Zero area relative to the edge lengths (a needle or a point).
        const double area2 = length(cross(e1, e2));
        const double scale = std::max(dot(e1, e1), dot(e2, e2));
        if (!(area2 > 1e-12 * scale) || !std::isfinite(area2)) continue;
        mesh.indices[3 * kept] = a;
        mesh.indices[3 * kept + 1] = b;
        mesh.indices[3 * kept + 2] = c;
        if (!mesh.materials.empty()) mesh.materials[kept] = mesh.materials[t];
        ++kept;
    }
    mesh.indices.resize(3 * kept);
    if (!mesh.materials.empty()) mesh.materials.resize(kept);
    return m - kept;
}

std::size_t removeUnusedVertices(Mesh& mesh) {
    validateIndices(mesh);
    const std::size_t n = mesh.vertexCount();
    std::vector<std::uint32_t> remap(n, UINT32_MAX);
    for (std::uint32_t i : mesh.indices) remap[i] = 0;
    std::uint32_t next = 0;  // keep the vertices' order
    for (std::uint32_t& r : remap)
        if (r == 0) r = next++;
    if (next == n) return 0;
    for (std::uint32_t& i : mesh.indices) i = remap[i];
    auto compact = [&](auto& attr) {
        if (attr.size() != n) return;
        std::remove_reference_t<decltype(attr)> out(next);
        for (std::size_t v = 0; v < n; ++v)
            if (remap[v] != UINT32_MAX) out[remap[v]] = attr[v];
        attr = std::move(out);
    };
    compact(mesh.positions);
    compact(mesh.normals);
    compact(mesh.uvs);
    compact(mesh.tangents);
    compact(mesh.colors);
    return n - next;
}

void flipOrientation(Mesh& mesh) noexcept {
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) std::swap(mesh.indices[t + 1], mesh.indices[t + 2]);
    for (Vec3& N : mesh.normals) N = {-N[0], -N[1], -N[2]};
    for (Vec4& T : mesh.tangents) T[3] = -T[3];
}

}  // namespace mucosa::mesh
