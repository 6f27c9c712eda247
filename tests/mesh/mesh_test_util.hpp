#pragma once
// Crafted meshes and glTF parsing shared by the mesh tests.
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/mesh/mesh.hpp>

#include "test_support.hpp"

namespace mucosa::test {

using mesh::Mesh;
using mesh::Vec2;
using mesh::Vec3;
using mesh::Vec4;

// A command's stderr: progress lines may precede it; exactly one line is the
// error, and it is the last.
inline void expectOneErrorLine(const std::string& err, const std::string& what) {
    int errors = 0;
    std::string last;
    std::istringstream in(err);
    for (std::string l; std::getline(in, l);) {
        errors += l.rfind("error: ", 0) == 0 ? 1 : 0;
        last = l;
    }
    EXPECT_EQ(errors, 1) << what << ": " << err;
    EXPECT_EQ(last.rfind("error: ", 0), 0u) << what << ": " << err;
}

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
    const std::size_t comps =
        std::map<std::string, int>{{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}}.at(acc["type"]);
    const std::size_t count = acc["count"];
    const std::size_t offset = view.value("byteOffset", 0) + acc.value("byteOffset", 0);
    std::vector<float> out(count * comps);
    std::memcpy(out.data(), g.bin.data() + offset, out.size() * 4);
    return out;
}

// The Khronos validator's accessor rules, checked on our own output:
// POSITION has min/max equal to the data, NORMAL unit, TANGENT xyz unit with
// w = +-1, indices in range, views 4-byte aligned and inside the buffer.
inline void checkGltfRules(const Glb& g, std::size_t expectVertices) {
    const auto& j = g.json;
    ASSERT_EQ(j["asset"]["version"], "2.0");
    ASSERT_EQ(j["buffers"].size(), 1u);
    ASSERT_EQ(j["buffers"][0]["byteLength"].get<std::size_t>(), g.bin.size());
    for (const auto& v : j["bufferViews"]) {
        EXPECT_EQ(v["byteOffset"].get<std::size_t>() % 4, 0u);
        EXPECT_LE(v["byteOffset"].get<std::size_t>() + v["byteLength"].get<std::size_t>(), g.bin.size());
    }
    const auto& prim = j["meshes"][0]["primitives"][0];
    const auto& attr = prim["attributes"];
    for (const char* name : {"POSITION", "NORMAL", "TEXCOORD_0", "TANGENT"}) ASSERT_TRUE(attr.contains(name)) << name;
    for (const auto& [name, a] : attr.items())
        EXPECT_EQ(j["accessors"][a.get<int>()]["count"].get<std::size_t>(), expectVertices);

    const int pa = attr["POSITION"];
    const auto P = accessorFloats(g, pa);
    const auto& acc = j["accessors"][pa];
    ASSERT_TRUE(acc.contains("min") && acc.contains("max"));
    for (int k = 0; k < 3; ++k) {
        float lo = INFINITY, hi = -INFINITY;
        for (std::size_t v = 0; v < expectVertices; ++v)
            lo = std::min(lo, P[3 * v + k]), hi = std::max(hi, P[3 * v + k]);
        EXPECT_EQ(acc["min"][k].get<float>(), lo);
        EXPECT_EQ(acc["max"][k].get<float>(), hi);
    }
    const auto N = accessorFloats(g, attr["NORMAL"]);
    for (std::size_t v = 0; v < expectVertices; ++v) {
        const double l = std::sqrt(double(N[3 * v]) * N[3 * v] + double(N[3 * v + 1]) * N[3 * v + 1] +
                                   double(N[3 * v + 2]) * N[3 * v + 2]);
        ASSERT_NEAR(l, 1.0, 5e-4) << "normal " << v;
    }
    const auto T = accessorFloats(g, attr["TANGENT"]);
    for (std::size_t v = 0; v < expectVertices; ++v) {
        const double l = std::sqrt(double(T[4 * v]) * T[4 * v] + double(T[4 * v + 1]) * T[4 * v + 1] +
                                   double(T[4 * v + 2]) * T[4 * v + 2]);
        ASSERT_NEAR(l, 1.0, 5e-4) << "tangent " << v;
        ASSERT_TRUE(T[4 * v + 3] == 1.0f || T[4 * v + 3] == -1.0f) << "tangent w " << v;
    }
    const auto& ia = j["accessors"][prim["indices"].get<int>()];
    const auto& iv = j["bufferViews"][ia["bufferView"].get<int>()];
    const std::size_t count = ia["count"];
    ASSERT_EQ(count % 3, 0u);
    for (std::size_t i = 0; i < count; ++i) {
        std::uint32_t idx = 0;
        const std::size_t at = iv["byteOffset"].get<std::size_t>();
        if (ia["componentType"] == 5123) {
            std::uint16_t s;
            std::memcpy(&s, g.bin.data() + at + 2 * i, 2);
            idx = s;
        } else {
            ASSERT_EQ(ia["componentType"], 5125);
            std::memcpy(&idx, g.bin.data() + at + 4 * i, 4);
        }
        ASSERT_LT(idx, expectVertices);
    }
    EXPECT_EQ(prim.value("mode", 4), 4);
}

}  // namespace mucosa::test
