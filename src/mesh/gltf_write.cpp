// glTF 2.0 writer (own, on nlohmann-json): one mesh, one primitive per
// material over shared vertex arrays (the attributes a normal-mapped surface
// needs), and the materials, textures and images of a GltfLook. Written by hand rather than with
// tinygltf or Assimp's exporter because the accessor rules the Khronos
// validator checks (exact min/max, unit normals, w = +-1) and the single
// atomic write are easiest to guarantee where every byte is ours.
#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/core/version.hpp>
#include <mucosa/mesh/gltf.hpp>
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

// Whether a material reads a normal texture (so its primitives use TANGENT):
// the ones the Khronos validator counts.
bool readsNormalTexture(const nlohmann::json& material) {
    if (!material.is_object()) return false;
    if (material.contains("normalTexture")) return true;
    if (!material.contains("extensions") || !material["extensions"].is_object()) return false;
    const nlohmann::json& e = material["extensions"];
    return (e.contains("KHR_materials_clearcoat") && e["KHR_materials_clearcoat"].contains("clearcoatNormalTexture")) ||
           (e.contains("KHR_materials_anisotropy") && e["KHR_materials_anisotropy"].contains("anisotropyTexture"));
}

}  // namespace

void writeGltf(const Mesh& mesh, const std::filesystem::path& path, bool binary, const SaveOptions& options) {
    using J = nlohmann::json;
    validateIndices(mesh, path.string());
    if (mesh.triangleCount() == 0) throw InputError("mesh", path.string(), "nothing to write: no triangles");
    const GltfLook* look = options.look;
    // Which material each triangle has (kNoMaterial: none), checked against the look.
    const std::size_t materialCount = look ? look->materials.size() : 1;
    auto materialOf = [&](std::size_t t) -> std::uint32_t {
        if (!mesh.materials.empty()) return mesh.materials[t];
        return materialCount > 0 ? 0u : kNoMaterial;
    };
    std::vector<std::uint32_t> used;  // material indices in use, ascending, kNoMaterial last
    {
        std::vector<char> seen(materialCount, 0);
        bool none = false;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            const std::uint32_t m = materialOf(t);
            if (m == kNoMaterial)
                none = true;
            else if (m >= materialCount)
                throw InputError("materials", path.string(),
                                 fmt::format("triangle {} has material {} of {}", t, m, materialCount));
            else
                seen[m] = 1;
        }
        for (std::size_t m = 0; m < materialCount; ++m)
            if (seen[m]) used.push_back(static_cast<std::uint32_t>(m));
        if (none) used.push_back(kNoMaterial);
    }
    if (look) {
        if (look->images.size() != look->imageData.size())
            throw InputError("images", path.string(), "image payloads do not match the images");
        if (maxTexCoord(*look) > 0)
            throw InputError("materials", path.string(),
                             fmt::format("a material reads TEXCOORD_{}; Mucosa writes one set of texture coordinates",
                                         maxTexCoord(*look)));
        if (!mesh.hasUvs())
            for (std::uint32_t m : used)
                if (m != kNoMaterial && readsTexture(look->materials[m]))
                    throw InputError(
                        "materials", path.string(),
                        fmt::format("material {} has textures but the mesh has no texture coordinates", m));
    }
    // TANGENT for the primitives whose material reads a normal texture (all of
    // them without a look).
    auto wantsTangents = [&](std::uint32_t m) {
        return !look || (m != kNoMaterial && readsNormalTexture(look->materials[m]));
    };
    const bool tangents =
        mesh.hasTangents() && mesh.hasNormals() && std::any_of(used.begin(), used.end(), wantsTangents);

    requireWritable(path);
    const std::size_t n = mesh.vertexCount();
    std::uint64_t imageBytes = 0;
    if (look)
        for (const auto& d : look->imageData) imageBytes += d.size();
    requireMemory(saturatingMul(n, (48 + (mesh.hasColors() ? 12 : 0)) * 3) + saturatingMul(mesh.indices.size(), 4 * 3) +
                      saturatingMul(imageBytes, binary ? 2 : 4),
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
    int tangentAccessor = -1;
    if (tangents) {
        // xyz unit, w = +-1: B = w cross(N, T) (glTF 2.0, "Meshes", TANGENT).
        // The handedness keeps its meaning through the v flip: glTF defines B
        // as pointing along the texture's +v in the OpenGL sense, as ours.
        std::vector<Vec4> T(n);
        for (std::size_t v = 0; v < n; ++v) {
            const Vec3 t = unit({mesh.tangents[v][0], mesh.tangents[v][1], mesh.tangents[v][2]}, Vec3{1, 0, 0});
            T[v] = {t[0], t[1], t[2], mesh.tangents[v][3] < 0 ? -1.0f : 1.0f};
        }
        tangentAccessor = b.add(T.data(), n * sizeof(Vec4), n, kFloat, "VEC4", kArrayBuffer);
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
    // One primitive per material: its triangles in their order, the vertex arrays shared.
    J primitives = J::array();
    for (std::uint32_t m : used) {
        std::vector<std::uint32_t> idx;
        idx.reserve(used.size() == 1 ? mesh.indices.size() : 0);
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t)
            if (materialOf(t) == m)
                idx.insert(idx.end(), mesh.indices.begin() + 3 * t, mesh.indices.begin() + 3 * t + 3);
        int indices;
        if (n <= 65535) {
            std::vector<std::uint16_t> I(idx.begin(), idx.end());
            indices = b.add(I.data(), I.size() * 2, I.size(), kUnsignedShort, "SCALAR", kElementArrayBuffer);
        } else {
            indices = b.add(idx.data(), idx.size() * 4, idx.size(), kUnsignedInt, "SCALAR", kElementArrayBuffer);
        }
        J a = attributes;
        if (tangentAccessor >= 0 && wantsTangents(m)) a["TANGENT"] = tangentAccessor;
        J prim = {{"attributes", a}, {"indices", indices}, {"mode", 4}};
        if (m != kNoMaterial) prim["material"] = m;
        primitives.push_back(std::move(prim));
    }

    nlohmann::json doc;
    doc["asset"] = {{"version", "2.0"}, {"generator", "Mucosa " + std::string(version())}};
    doc["scene"] = 0;
    // Arrays are spelled json::array(): a braced list of one element is an
    // array for GCC but a copy of the element for clang (CWG 2137).
    doc["scenes"] = J::array({J{{"nodes", J::array({0})}}});
    doc["nodes"] = J::array({J{{"mesh", 0}, {"name", options.name}}});
    if (look) {
        std::vector<std::string> extensions;
        for (const J* part : {&look->materials, &look->textures, &look->samplers, &look->images})
            collectExtensions(*part, extensions);
        if (!extensions.empty()) {
            doc["extensionsUsed"] = extensions;
            J required = J::array();
            for (const std::string& e : look->extensionsRequired)
                if (std::find(extensions.begin(), extensions.end(), e) != extensions.end()) required.push_back(e);
            if (!required.empty()) doc["extensionsRequired"] = required;
        }
        if (!look->materials.empty()) doc["materials"] = look->materials;
        if (!look->textures.empty()) doc["textures"] = look->textures;
        if (!look->samplers.empty()) doc["samplers"] = look->samplers;
        if (!look->images.empty()) {
            J images = J::array();
            for (std::size_t i = 0; i < look->images.size(); ++i) {
                J image = look->images[i];
                const auto& data = look->imageData[i];
                const std::string mime = image.value("mimeType", "");
                if (mime.empty()) throw InputError("images", path.string(), fmt::format("image {} has no mimeType", i));
                if (binary) {
                    while (b.bin.size() % 4) b.bin.push_back(0);
                    const std::size_t offset = b.bin.size();
                    b.bin.insert(b.bin.end(), data.begin(), data.end());
                    b.views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", data.size()}});
                    image["bufferView"] = b.views.size() - 1;
                } else {
                    image.erase("mimeType");  // the data URI names it
                    image["uri"] = "data:" + mime + ";base64," + base64(data);
                }
                images.push_back(std::move(image));
            }
            doc["images"] = std::move(images);
        }
    } else {
        doc["materials"] = J::array({J{{"name", "mucosa"},
                                       {"pbrMetallicRoughness",
                                        {{"baseColorFactor", J::array({0.80, 0.36, 0.34, 1.0})},
                                         {"metallicFactor", 0.0},
                                         {"roughnessFactor", 0.35}}}}});
    }
    while (b.bin.size() % 4) b.bin.push_back(0);
    doc["meshes"] = J::array({J{{"name", options.name}, {"primitives", std::move(primitives)}}});
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
