#include "adjacency.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <unordered_map>

namespace mucosa::mesh::detail {

VertexCorners vertexCorners(const Mesh& mesh) {
    VertexCorners vc;
    const std::size_t n = mesh.vertexCount();
    vc.offsets.assign(n + 1, 0);
    for (std::uint32_t i : mesh.indices) ++vc.offsets[i + 1];
    for (std::size_t v = 0; v < n; ++v) vc.offsets[v + 1] += vc.offsets[v];
    vc.corners.resize(mesh.indices.size());
    std::vector<std::uint32_t> fill(vc.offsets.begin(), vc.offsets.end() - 1);
    for (std::size_t c = 0; c < mesh.indices.size(); ++c)
        vc.corners[fill[mesh.indices[c]]++] = static_cast<std::uint32_t>(c);
    return vc;
}

namespace {
struct PosHash {
    std::size_t operator()(const Vec3& p) const noexcept {
        std::uint32_t x = std::bit_cast<std::uint32_t>(p[0]), y = std::bit_cast<std::uint32_t>(p[1]),
                      z = std::bit_cast<std::uint32_t>(p[2]);
        std::uint64_t h = x * 0x9E3779B97F4A7C15ull;
        h ^= (y + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2));
        h ^= (z * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2));
        return static_cast<std::size_t>(h ^ (h >> 29));
    }
};
struct PosEq {
    bool operator()(const Vec3& a, const Vec3& b) const noexcept {
        return std::memcmp(a.data(), b.data(), sizeof(Vec3)) == 0;
    }
};
}  // namespace

std::size_t positionIds(const Mesh& mesh, std::vector<std::uint32_t>& ids) {
    const std::size_t n = mesh.vertexCount();
    ids.resize(n);
    std::unordered_map<Vec3, std::uint32_t, PosHash, PosEq> first;
    first.reserve(n);
    for (std::size_t v = 0; v < n; ++v) {
        Vec3 p = mesh.positions[v];
        for (float& c : p)
            if (c == 0.0f) c = 0.0f;  // -0 and +0 are one position
        ids[v] = first.try_emplace(p, static_cast<std::uint32_t>(v)).first->second;
    }
    return first.size();
}

std::vector<EdgeUse> edgeUses(const Mesh& mesh, const std::vector<std::uint32_t>& ids) {
    const std::size_t m = mesh.indices.size();
    // key = (min << 32 | max) << 1 | (traversed min -> max)
    std::vector<std::pair<std::uint64_t, std::uint8_t>> keys;
    keys.reserve(m);
    for (std::size_t t = 0; t + 2 < m; t += 3) {
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = ids[mesh.indices[t + k]], b = ids[mesh.indices[t + (k + 1) % 3]];
            if (a == b) continue;
            const std::uint32_t lo = std::min(a, b), hi = std::max(a, b);
            keys.emplace_back((std::uint64_t{lo} << 32) | hi, a < b ? 1 : 0);
        }
    }
    std::sort(keys.begin(), keys.end());
    std::vector<EdgeUse> edges;
    for (std::size_t i = 0; i < keys.size();) {
        std::size_t j = i;
        std::uint32_t forward = 0;
        while (j < keys.size() && keys[j].first == keys[i].first) forward += keys[j++].second;
        edges.push_back({static_cast<std::uint32_t>(keys[i].first >> 32), static_cast<std::uint32_t>(keys[i].first),
                         static_cast<std::uint32_t>(j - i), forward});
        i = j;
    }
    return edges;
}

}  // namespace mucosa::mesh::detail
