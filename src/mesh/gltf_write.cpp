// glTF 2.0 writer (own, on nlohmann-json): one mesh, one primitive, the four
// attributes a normal-mapped surface needs. Written by hand rather than with
// tinygltf or Assimp's exporter because the accessor rules the Khronos
// validator checks (exact min/max, unit normals, w = +-1) and the single
// atomic write are easiest to guarantee where every byte is ours.
#include <algorithm>
#include <cmath>
#include <cstring>

#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/core/version.hpp>
#include <mucosa/mesh/io.hpp>

#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;

namespace {

constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A, kChunkBin = 0x004E4942;
constexpr int kFloat = 5126, kUnsignedShort = 5123, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr float kMetresPerMillimetre = 0.001f;

std::string base64(const std::vector<std::uint8_t>& bytes) {
    static constexpr char kTable[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3) {
        const std::uint32_t v = std::uint32_t{bytes[i]} << 16 | std::uint32_t{bytes[i + 1]} << 8 | bytes[i + 2];
        out += kTable[v >> 18];
        out += kTable[(v >> 12) & 63];
        out += kTable[(v >> 6) & 63];
        out += kTable[v & 63];
    }
    if (i < bytes.size()) {
        std::uint32_t v = std::uint32_t{bytes[i]} << 16;
        if (i + 1 < bytes.size()) v |= std::uint32_t{bytes[i + 1]} << 8;
        out += kTable[v >> 18];
        out += kTable[(v >> 12) & 63];
        out += i + 1 < bytes.size() ? kTable[(v >> 6) & 63] : '=';
        out += '=';
    }
    return out;
}

struct Builder {
    std::vector<std::uint8_t> bin;
    nlohmann::json views = nlohmann::json::array(), accessors = nlohmann::json::array();

    // Appends a tightly packed view (4-byte aligned) and its accessor.
    int add(const void* data, std::size_t bytes, std::size_t count, int componentType, const char* type, int target,
            const nlohmann::json& extra = nullptr) {
        while (bin.size() % 4) bin.push_back(0);
        const std::size_t offset = bin.size();
        bin.resize(offset + bytes);
        std::memcpy(bin.data() + offset, data, bytes);
        views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}, {"target", target}});
        nlohmann::json a = {
            {"bufferView", views.size() - 1}, {"componentType", componentType}, {"count", count}, {"type", type}};
        if (!extra.is_null()) a.update(extra);
        accessors.push_back(a);
        return static_cast<int>(accessors.size() - 1);
    }
};

// Unit length in float: the validator allows |1 - |v|| <= 0.0005.
Vec3 unit(const Vec3& v, const Vec3& fallback) {
    const Vec3d d = normalizeOr(toD(v), toD(fallback));
    return toF(d);
}

}  // namespace

void writeGltf(const Mesh& mesh, const std::filesystem::path& path, bool binary, const SaveOptions& options) {
    validateIndices(mesh, path.string());
    if (mesh.triangleCount() == 0) throw InputError("mesh", path.string(), "nothing to write: no triangles");
    requireWritable(path);
    const std::size_t n = mesh.vertexCount();
    requireMemory(saturatingMul(n, (48 + (mesh.hasColors() ? 12 : 0)) * 3) + saturatingMul(mesh.indices.size(), 4 * 3),
                  "glTF output");

    Builder b;
    nlohmann::json attributes;

    // POSITION in metres (glTF's unit) with exact min/max of the written floats.
    std::vector<Vec3> P(n);
    Vec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (std::size_t v = 0; v < n; ++v) {
        for (int k = 0; k < 3; ++k) {
            const float c = mesh.positions[v][k] * kMetresPerMillimetre;
            if (!std::isfinite(c)) throw InputError("mesh", path.string(), "non-finite vertex position");
            P[v][k] = c;
            lo[k] = std::min(lo[k], c);
            hi[k] = std::max(hi[k], c);
        }
    }
    attributes["POSITION"] = b.add(P.data(), n * sizeof(Vec3), n, kFloat, "VEC3", kArrayBuffer,
                                   {{"min", {lo[0], lo[1], lo[2]}}, {"max", {hi[0], hi[1], hi[2]}}});
    P = {};

    if (mesh.hasNormals()) {
        std::vector<Vec3> N(n);
        for (std::size_t v = 0; v < n; ++v) N[v] = unit(mesh.normals[v], Vec3{0, 0, 1});
        attributes["NORMAL"] = b.add(N.data(), n * sizeof(Vec3), n, kFloat, "VEC3", kArrayBuffer);
    }
    if (mesh.hasUvs()) {
        // glTF's UV origin is the top-left: v' = 1 - v (the one flip on the way out).
        std::vector<Vec2> uv(n);
        for (std::size_t v = 0; v < n; ++v) uv[v] = {mesh.uvs[v][0], 1.0f - mesh.uvs[v][1]};
        attributes["TEXCOORD_0"] = b.add(uv.data(), n * sizeof(Vec2), n, kFloat, "VEC2", kArrayBuffer);
    }
    if (mesh.hasTangents() && mesh.hasNormals()) {
        // xyz unit, w = +-1: B = w cross(N, T) (glTF 2.0, "Meshes", TANGENT).
        // The handedness keeps its meaning through the v flip: glTF defines B
        // as pointing along the texture's +v in the OpenGL sense, as ours.
        std::vector<Vec4> T(n);
        for (std::size_t v = 0; v < n; ++v) {
            const Vec3 t = unit({mesh.tangents[v][0], mesh.tangents[v][1], mesh.tangents[v][2]}, Vec3{1, 0, 0});
            T[v] = {t[0], t[1], t[2], mesh.tangents[v][3] < 0 ? -1.0f : 1.0f};
        }
        attributes["TANGENT"] = b.add(T.data(), n * sizeof(Vec4), n, kFloat, "VEC4", kArrayBuffer);
    }
    if (mesh.hasColors()) {
        // COLOR_0: linear RGB float VEC3 (glTF 2.0, "Meshes": multiplies the
        // base colour), clamped to the 0..1 the specification allows.
        std::vector<Vec3> C(n);
        for (std::size_t v = 0; v < n; ++v)
            for (int k = 0; k < 3; ++k) {
                const float c = mesh.colors[v][k];
                if (!std::isfinite(c)) throw InputError("mesh", path.string(), "non-finite vertex colour");
                C[v][k] = std::clamp(c, 0.0f, 1.0f);
            }
        attributes["COLOR_0"] = b.add(C.data(), n * sizeof(Vec3), n, kFloat, "VEC3", kArrayBuffer);
    }
    int indices;
    if (n <= 65535) {
        std::vector<std::uint16_t> I(mesh.indices.begin(), mesh.indices.end());
        indices = b.add(I.data(), I.size() * 2, I.size(), kUnsignedShort, "SCALAR", kElementArrayBuffer);
    } else {
        indices = b.add(mesh.indices.data(), mesh.indices.size() * 4, mesh.indices.size(), kUnsignedInt, "SCALAR",
                        kElementArrayBuffer);
    }
    while (b.bin.size() % 4) b.bin.push_back(0);

    nlohmann::json doc;
    doc["asset"] = {{"version", "2.0"}, {"generator", "Mucosa " + std::string(version())}};
    doc["scene"] = 0;
    // Arrays are spelled json::array(): a braced list of one element is an
    // array for GCC but a copy of the element for clang (CWG 2137).
    using J = nlohmann::json;
    doc["scenes"] = J::array({J{{"nodes", J::array({0})}}});
    doc["nodes"] = J::array({J{{"mesh", 0}, {"name", options.name}}});
    doc["materials"] = J::array({J{{"name", "mucosa"},
                                   {"pbrMetallicRoughness",
                                    {{"baseColorFactor", J::array({0.80, 0.36, 0.34, 1.0})},
                                     {"metallicFactor", 0.0},
                                     {"roughnessFactor", 0.35}}}}});
    doc["meshes"] =
        J::array({J{{"name", options.name},
                    {"primitives",
                     J::array({J{{"attributes", attributes}, {"indices", indices}, {"material", 0}, {"mode", 4}}})}}});
    doc["accessors"] = std::move(b.accessors);
    doc["bufferViews"] = std::move(b.views);
    nlohmann::json buffer = {{"byteLength", b.bin.size()}};
    if (!binary) buffer["uri"] = "data:application/octet-stream;base64," + base64(b.bin);
    doc["buffers"] = J::array({buffer});

    AtomicFile out(path);
    if (binary) {
        std::string json = doc.dump();
        while (json.size() % 4) json += ' ';
        const std::uint32_t total = static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + b.bin.size());
        if (12ull + 8 + json.size() + 8 + b.bin.size() > 0xFFFFFFFFull)
            throw InputError("mesh", path.string(), "too large for a .glb (4 GiB); write .gltf, .ply or .obj");
        const std::uint32_t header[3] = {kGlbMagic, 2, total};
        out.write(header, sizeof header);
        const std::uint32_t jsonChunk[2] = {static_cast<std::uint32_t>(json.size()), kChunkJson};
        out.write(jsonChunk, sizeof jsonChunk);
        out.write(json);
        const std::uint32_t binChunk[2] = {static_cast<std::uint32_t>(b.bin.size()), kChunkBin};
        out.write(binChunk, sizeof binChunk);
        out.write(b.bin.data(), b.bin.size());
    } else {
        out.write(doc.dump(1) + "\n");
    }
    out.commit();
}

}  // namespace mucosa::mesh
