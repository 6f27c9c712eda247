#pragma once
// Crafted meshes and glTF parsing shared by the mesh tests.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <mucosa/mesh/mesh.hpp>

#include "test_support.hpp"

namespace mucosa::test {

using mesh::Mesh;
using mesh::Vec2;
using mesh::Vec3;
using mesh::Vec4;

inline double angleDeg(const Vec3& a, const Vec3& b) {
    const double d = double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2];
    const double la = std::sqrt(double(a[0]) * a[0] + double(a[1]) * a[1] + double(a[2]) * a[2]);
    const double lb = std::sqrt(double(b[0]) * b[0] + double(b[1]) * b[1] + double(b[2]) * b[2]);
    return std::acos(std::clamp(d / (la * lb), -1.0, 1.0)) * 180.0 / M_PI;
}

// A flat n x n grid in the z = 0 plane (normals +z), uv = (x, y) / n.
inline Mesh grid(int n) {
    Mesh m;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            m.positions.push_back({float(i), float(j), 0});
            m.normals.push_back({0, 0, 1});
            m.uvs.push_back({float(i) / float(n), float(j) / float(n)});
        }
    auto id = [n](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            m.indices.insert(m.indices.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1)});
            m.indices.insert(m.indices.end(), {id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
    return m;
}

// A parsed .glb: its JSON and binary chunk.
struct Glb {
    nlohmann::json json;
    std::string bin;
};

inline Glb parseGlb(const std::string& bytes) {
    Glb g;
    auto u32 = [&](std::size_t at) {
        std::uint32_t v;
        std::memcpy(&v, bytes.data() + at, 4);
        return v;
    };
    if (bytes.size() < 20 || u32(0) != 0x46546C67 || u32(4) != 2) throw std::runtime_error("not a glb");
    if (u32(8) != bytes.size()) throw std::runtime_error("glb length field wrong");
    const std::uint32_t jsonLen = u32(12);
    if (u32(16) != 0x4E4F534A) throw std::runtime_error("first chunk is not JSON");
    g.json = nlohmann::json::parse(bytes.substr(20, jsonLen));
    const std::size_t binAt = 20 + jsonLen;
    if (binAt < bytes.size()) {
        if (u32(binAt + 4) != 0x004E4942) throw std::runtime_error("second chunk is not BIN");
        g.bin = bytes.substr(binAt + 8, u32(binAt));
    }
    return g;
}

// Reads accessor `a` as floats (FLOAT components only).
inline std::vector<float> accessorFloats(const Glb& g, int a) {
    const auto& acc = g.json["accessors"][a];
    const auto& view = g.json["bufferViews"][acc["bufferView"].get<int>()];
    const std::size_t comps = std::map<std::string, int>{{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}}.at(acc["type"]);
    const std::size_t count = acc["count"];
    const std::size_t offset = view.value("byteOffset", 0) + acc.value("byteOffset", 0);
    std::vector<float> out(count * comps);
    std::memcpy(out.data(), g.bin.data() + offset, out.size() * 4);
    return out;
}

}  // namespace mucosa::test
