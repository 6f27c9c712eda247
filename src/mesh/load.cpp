// Import through Assimp: every format it reads, merged into one Mesh in mm.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include <assimp/DefaultIOSystem.h>
#include <assimp/importerdesc.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <assimp/Importer.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/mesh/gltf.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/repair.hpp>

#include "core/isolate.hpp"
#include "import_checks.hpp"
#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;  // mesh::detail

namespace {

std::string lowerExtension(const std::filesystem::path& p) {
    std::string e = p.extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return e;
}

// Assimp opens every file through this: the model itself and what it names
// (glTF buffers and images, OBJ material libraries) only inside the model's
// folder. What is refused is reported as a warning (an OBJ still loads
// without its materials, which Mucosa does not use).
class ConfinedIOSystem : public Assimp::DefaultIOSystem {
public:
    ConfinedIOSystem(std::filesystem::path model, std::vector<std::string>& refused)
        : model_(std::move(model)), refused_(refused) {}
    bool Exists(const char* file) const override { return allowed(file) && DefaultIOSystem::Exists(file); }
    Assimp::IOStream* Open(const char* file, const char* mode = "rb") override {
        if (!allowed(file) || std::strpbrk(mode, "wa+") != nullptr) {
            refused_.push_back(file);
            return nullptr;
        }
        return DefaultIOSystem::Open(file, mode);
    }

private:
    bool allowed(const char* file) const {
        // Assimp hands over paths already joined to the model's folder (or
        // absolute ones, when the file wrote them so): compare resolved paths.
        return std::filesystem::path(file) == model_ || resolvesInside(model_.parent_path(), file);
    }
    std::filesystem::path model_;
    std::vector<std::string>& refused_;
};

// What the isolated importer sends back: the merged mesh and the facts for
// LoadInfo, as little-endian bytes (same machine, same build: no versioning).
struct Imported {
    Mesh mesh;
    std::string format;
    std::size_t subMeshes = 0, droppedPrimitives = 0;
    bool allNormals = false, allUvs = false, allTangents = false, allColors = false;
    std::uint64_t materialCount = 0;  // Assimp's materials (aiScene::mNumMaterials)
    std::vector<std::string> warnings;
};

class Writer {
public:
    void u64(std::uint64_t v) { bytes_.append(reinterpret_cast<const char*>(&v), 8); }
    void str(const std::string& s) {
        u64(s.size());
        bytes_ += s;
    }
    template <class T>
    void array(const std::vector<T>& v) {
        u64(v.size());
        if (!v.empty()) bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    }
    std::string take() { return std::move(bytes_); }

private:
    std::string bytes_;
};

class Reader {
public:
    Reader(const std::string& bytes, const std::string& file) : bytes_(bytes), file_(file) {}
    std::uint64_t u64() {
        need(8);
        std::uint64_t v;
        std::memcpy(&v, bytes_.data() + at_, 8);
        at_ += 8;
        return v;
    }
    std::string str() {
        const std::uint64_t n = u64();
        need(n);
        std::string s(bytes_, at_, n);
        at_ += n;
        return s;
    }
    template <class T>
    void array(std::vector<T>& v) {
        const std::uint64_t n = u64();
        if (n > (bytes_.size() - at_) / sizeof(T)) fail();
        v.resize(n);
        if (n > 0) std::memcpy(v.data(), bytes_.data() + at_, n * sizeof(T));
        at_ += n * sizeof(T);
    }
    bool done() const { return at_ == bytes_.size(); }

private:
    void need(std::uint64_t n) const {
        if (n > bytes_.size() - at_) fail();
    }
    [[noreturn]] void fail() const { throw InputError("mesh", file_, "the importer's result is malformed"); }
    const std::string& bytes_;
    std::string file_;
    std::size_t at_ = 0;
};

std::string encode(const Imported& r) {
    Writer w;
    w.str(r.format);
    w.u64(r.subMeshes);
    w.u64(r.droppedPrimitives);
    w.u64((r.allNormals ? 1 : 0) | (r.allUvs ? 2 : 0) | (r.allTangents ? 4 : 0) | (r.allColors ? 8 : 0));
    w.u64(r.materialCount);
    w.u64(r.warnings.size());
    for (const std::string& s : r.warnings) w.str(s);
    w.array(r.mesh.positions);
    w.array(r.mesh.normals);
    w.array(r.mesh.uvs);
    w.array(r.mesh.tangents);
    w.array(r.mesh.colors);
    w.array(r.mesh.indices);
    w.array(r.mesh.materials);
    return w.take();
}

Imported decode(const std::string& bytes, const std::string& file) {
    Reader r(bytes, file);
    Imported out;
    out.format = r.str();
    out.subMeshes = r.u64();
    out.droppedPrimitives = r.u64();
    const std::uint64_t flags = r.u64();
    out.allNormals = flags & 1, out.allUvs = flags & 2, out.allTangents = flags & 4, out.allColors = flags & 8;
    out.materialCount = r.u64();
    const std::uint64_t warnings = r.u64();
    for (std::uint64_t i = 0; i < warnings && i < 1000; ++i) out.warnings.push_back(r.str());
    r.array(out.mesh.positions);
    r.array(out.mesh.normals);
    r.array(out.mesh.uvs);
    r.array(out.mesh.tangents);
    r.array(out.mesh.colors);
    r.array(out.mesh.indices);
    r.array(out.mesh.materials);
    if (!r.done()) throw InputError("mesh", file, "the importer's result is malformed");
    // The child's output is checked like any input: lengths agree, indices in range.
    validateIndices(out.mesh, file);
    return out;
}

// Runs in the isolated child: Assimp reads the file, every triangle mesh is
// merged into one Mesh (as stored: no unit scale, no normal repair yet).
Imported importWithAssimp(const std::filesystem::path& path, const std::string& ext) {
    const std::string name = path.string();
    Imported out;
    Assimp::Importer importer;
    std::vector<std::string> refused;
    importer.SetIOHandler(new ConfinedIOSystem(path, refused));  // the importer owns it
    // Lossless steps only: triangulate polygons, apply node transforms, merge
    // vertices whose every attribute is equal, and keep points/lines apart.
    importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
    const unsigned flags = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices |
                           aiProcess_SortByPType | aiProcess_ValidateDataStructure;
    const aiScene* scene = nullptr;
    try {
        scene = importer.ReadFile(name, flags);
    } catch (const std::exception& e) {
        throw InputError("mesh", name, e.what());
    }
    for (const std::string& r : refused)
        out.warnings.push_back(fmt::format("did not read '{}': outside the model's folder", r));
    if (!scene) {
        std::string why = importer.GetErrorString();
        if (why.empty()) why = "the importer could not read it";
        if (!refused.empty()) why += fmt::format(" ('{}' is outside the model's folder and was not read)", refused[0]);
        throw InputError("mesh", name, why);
    }
    if (const aiImporterDesc* d = importer.GetImporterInfo(importer.GetImporterIndex(ext.c_str())))
        out.format = d->mName;

    // Count first, check memory, then copy.
    std::size_t vertices = 0, triangles = 0;
    bool allNormals = true, allUvs = true, allTangents = true, allColors = true;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const aiMesh* am = scene->mMeshes[m];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) {
            ++out.droppedPrimitives;
            continue;
        }
        ++out.subMeshes;
        vertices += am->mNumVertices;
        triangles += am->mNumFaces;
        allNormals = allNormals && am->HasNormals();
        allUvs = allUvs && am->HasTextureCoords(0);
        allTangents = allTangents && am->HasTangentsAndBitangents() && am->HasNormals();
        allColors = allColors && am->HasVertexColors(0);
    }
    if (triangles == 0) throw InputError("mesh", name, "the file contains no triangles");
    if (vertices > std::numeric_limits<std::uint32_t>::max() - 1 ||
        triangles > std::numeric_limits<std::uint32_t>::max() / 3)
        throw InputError("mesh", name,
                         fmt::format("{} vertices / {} triangles exceed 32-bit indices", vertices, triangles));
    requireMemory(
        saturatingMul(vertices, sizeof(Vec3) * 3 + sizeof(Vec2) + sizeof(Vec4)) + saturatingMul(triangles, 12),
        fmt::format("mesh '{}'", name));
    out.allNormals = allNormals;
    out.allUvs = allUvs;
    out.allTangents = allTangents;
    out.allColors = allColors;
    out.materialCount = scene->mNumMaterials;
    if (out.subMeshes > 1) {
        std::size_t anyUv = 0;
        for (unsigned m = 0; m < scene->mNumMeshes; ++m) anyUv += scene->mMeshes[m]->HasTextureCoords(0) ? 1 : 0;
        if (!allUvs && anyUv > 0)
            out.warnings.push_back("some parts have texture coordinates and some not: all dropped");
        std::size_t anyColor = 0;
        for (unsigned m = 0; m < scene->mNumMeshes; ++m) anyColor += scene->mMeshes[m]->HasVertexColors(0) ? 1 : 0;
        if (!allColors && anyColor > 0)
            out.warnings.push_back("some parts have vertex colours and some not: all dropped");
    }

    Mesh& mesh = out.mesh;
    mesh.positions.reserve(vertices);
    mesh.indices.reserve(3 * triangles);
    mesh.materials.reserve(triangles);
    if (allNormals) mesh.normals.reserve(vertices);
    if (allUvs) mesh.uvs.reserve(vertices);
    if (allTangents) mesh.tangents.reserve(vertices);
    if (allColors) mesh.colors.reserve(vertices);
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const aiMesh* am = scene->mMeshes[m];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
        const auto base = static_cast<std::uint32_t>(mesh.positions.size());
        for (unsigned v = 0; v < am->mNumVertices; ++v) {
            const aiVector3D& p = am->mVertices[v];
            mesh.positions.push_back({p.x, p.y, p.z});
            if (allNormals) mesh.normals.push_back({am->mNormals[v].x, am->mNormals[v].y, am->mNormals[v].z});
            // Assimp's UVs are OpenGL's (its glTF importer already flips v).
            if (allUvs) mesh.uvs.push_back({am->mTextureCoords[0][v].x, am->mTextureCoords[0][v].y});
            // The first colour set, RGB (alpha dropped: a tint, not coverage).
            if (allColors) mesh.colors.push_back({am->mColors[0][v].r, am->mColors[0][v].g, am->mColors[0][v].b});
            if (allTangents) {
                const Vec3 N{am->mNormals[v].x, am->mNormals[v].y, am->mNormals[v].z};
                const Vec3 T{am->mTangents[v].x, am->mTangents[v].y, am->mTangents[v].z};
                const Vec3 B{am->mBitangents[v].x, am->mBitangents[v].y, am->mBitangents[v].z};
                // Assimp keeps B = w cross(N, T) (glTF) or dP/dv: w = sign(dot(cross(N, T), B)).
                const float w = dot(cross(N, T), B) < 0.0f ? -1.0f : 1.0f;
                const Vec3 Tn = normalizeOr(T, Vec3{1, 0, 0});
                mesh.tangents.push_back({Tn[0], Tn[1], Tn[2], w});
            }
        }
        for (unsigned f = 0; f < am->mNumFaces; ++f) {
            const aiFace& face = am->mFaces[f];
            if (face.mNumIndices != 3) continue;
            for (int k = 0; k < 3; ++k) {
                if (face.mIndices[k] >= am->mNumVertices)
                    throw InputError("mesh", name,
                                     fmt::format("face {} has index {} out of range", f, face.mIndices[k]));
                mesh.indices.push_back(base + face.mIndices[k]);
            }
            mesh.materials.push_back(am->mMaterialIndex);
        }
    }
    if (mesh.indices.empty()) throw InputError("mesh", name, "the file contains no triangles");
    return out;
}

}  // namespace

bool isMeshFile(const std::filesystem::path& path) {
    const std::string ext = lowerExtension(path);
    return !ext.empty() && Assimp::Importer().IsExtensionSupported(ext);
}

Mesh load(const std::filesystem::path& path, const LoadOptions& options, LoadInfo* infoOut) {
    namespace fs = std::filesystem;
    const std::string name = path.string();
    std::error_code ec;
    if (!fs::exists(path, ec)) throw IoError("mesh", name, "no such file");
    if (fs::is_directory(path, ec)) throw IoError("mesh", name, "is a directory");
    const std::uintmax_t fileBytes = fs::file_size(path, ec);
    if (ec) throw IoError("mesh", name, ec.message());
    {
        std::ifstream probe(path, std::ios::binary);
        if (!probe) throw IoError("mesh", name, "cannot be opened for reading");
    }
    if (fileBytes == 0) throw InputError("mesh", name, "the file is empty");

    LoadInfo info;
    info.fileBytes = static_cast<std::size_t>(fileBytes);
    const std::string ext = lowerExtension(path);
    if (!isMeshFile(path))
        throw InputError("mesh", name, fmt::format("unsupported format '{}'", ext.empty() ? "(no extension)" : ext));
    checkDeclaredSizes(path, ext, fileBytes);
    if (ext == ".gltf" || ext == ".glb") checkGltf(path, ext == ".glb", fileBytes);
    // Parsers hold the file and the scene at once: refuse up front what cannot fit.
    requireMemory(saturatingMul(fileBytes, 6), fmt::format("importing '{}'", name));

    // Assimp runs in a child process with memory, CPU and time limits (see
    // core/isolate.hpp): a crash, a hang or an exhaustion inside it becomes an
    // InputError naming the file. The limits scale with the file: a real
    // 100 MB scan needs ~1 GB and seconds, a 1 KB file neither (Assimp reads
    // a 1.5 MB OBJ in ~0.1 s, so 10 s is ample headroom).
    mucosa::detail::IsolationLimits limits;
    const std::uint64_t mib = 1ull << 20;
    limits.memoryBytes = options.importMemoryBytes
                             ? options.importMemoryBytes
                             : std::min<std::uint64_t>(std::max<std::uint64_t>(512 * mib, saturatingMul(fileBytes, 40)),
                                                       std::max<std::uint64_t>(availableMemoryBytes() / 2, 256 * mib));
    // RLIMIT_CPU counts whole seconds.
    limits.cpuSeconds =
        std::ceil(options.importSeconds > 0 ? options.importSeconds : 10.0 + double(fileBytes) / double(mib));
    limits.wallSeconds = 2 * limits.cpuSeconds + 5;
    limits.maxResultBytes = limits.memoryBytes;
    Imported imported;
    if (options.isolate) {
        imported = decode(
            mucosa::detail::runIsolated([&] { return encode(importWithAssimp(path, ext)); }, limits, "mesh", name),
            name);
    } else {
        imported = importWithAssimp(path, ext);
    }
    Mesh mesh = std::move(imported.mesh);
    info.format = std::move(imported.format);
    info.subMeshes = imported.subMeshes;
    info.droppedPrimitives = imported.droppedPrimitives;
    info.fileHadNormals = imported.allNormals;
    info.fileHadUvs = imported.allUvs;
    info.fileHadTangents = imported.allTangents;
    info.fileHadColors = imported.allColors;
    info.warnings = std::move(imported.warnings);
    if (mesh.indices.empty()) throw InputError("mesh", name, "the file contains no triangles");

    // Materials: kept for glTF only, where they index the file's own
    // materials. Assimp's glTF 2.0 importer (5.2) creates the file's
    // materials in order and appends one default material, which primitives
    // without a material get: that last index becomes kNoMaterial.
    const bool gltf = ext == ".gltf" || ext == ".glb";
    if (gltf && imported.materialCount > 0) {
        info.fileMaterials = static_cast<std::size_t>(imported.materialCount - 1);
        for (std::uint32_t& m : mesh.materials)
            if (m >= info.fileMaterials) m = kNoMaterial;
    } else {
        mesh.materials.clear();
    }

    // Units.
    double scale = 1.0;
    if (options.unit != Unit::Auto) {
        scale = millimetresPer(options.unit);
        info.unitReason = "as requested";
    } else if (gltf) {
        scale = 1000.0;
        info.unitReason = "glTF is in metres";
    } else {
        Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
        for (const Vec3& p : mesh.positions)
            if (finite(p))
                for (int k = 0; k < 3; ++k)
                    lo[k] = std::min(lo[k], double(p[k])), hi[k] = std::max(hi[k], double(p[k]));
        const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 0.0});
        // Anatomy smaller than 2 mm across is not a plausible whole model; in
        // metres it is anything up to 2 m. (--unit overrides the guess.)
        if (extent > 0 && extent < 2.0) {
            scale = 1000.0;
            info.unitReason =
                fmt::format("assumed metres: the model is {:.4g} units across (use --unit to override)", extent);
        } else {
            info.unitReason =
                fmt::format("assumed millimetres: the model is {:.4g} units across (use --unit to override)", extent);
        }
    }
    info.scaleToMillimetres = scale;
    if (scale != 1.0)
        for (Vec3& p : mesh.positions)
            for (float& c : p) c = static_cast<float>(c * scale);
    info.upAxis = gltf ? "+Y (glTF)" : "as stored in the file (not rotated)";

    // Non-finite values, counted after the scale to mm: a glTF coordinate of
    // 1e36 is finite in float but infinite after x1000, and is refused as well.
    std::size_t nonFinite = 0;
    for (const Vec3& p : mesh.positions) nonFinite += finite(p) ? 0 : 1;
    if (nonFinite > 0 && !options.allowNonFinite)
        throw InputError("mesh", name,
                         fmt::format("non-finite (NaN/Inf) coordinates in millimetres at {} of {} vertices", nonFinite,
                                     mesh.positions.size()));

    // Colours are a tint in 0..1 (glTF's range for COLOR_0): a NaN or a value
    // out of range would carry into every frame, so it is clamped and counted.
    std::size_t clampedColors = 0;
    for (Vec3& c : mesh.colors) {
        bool changed = false;
        for (float& x : c) {
            const float y = std::isfinite(x) ? std::clamp(x, 0.0f, 1.0f) : 1.0f;
            changed = changed || y != x;
            x = y;
        }
        clampedColors += changed ? 1 : 0;
    }
    if (clampedColors > 0)
        info.warnings.push_back(fmt::format("vertex colours outside 0..1 (or not finite) clamped at {} of {} vertices",
                                            clampedColors, mesh.colors.size()));

    // Normals: unit length, and computed where missing or unusable.
    if (mesh.hasNormals()) {
        for (Vec3& N : mesh.normals) {
            const Vec3 u = normalizeOr(N, Vec3{0, 0, 0});
            if (u == Vec3{0, 0, 0}) ++info.repairedNormals;
            N = u;
        }
        if (info.repairedNormals > 0 && options.computeMissingNormals) {
            Mesh computed;
            computed.positions = mesh.positions;
            computed.indices = mesh.indices;
            recomputeNormals(computed);
            for (std::size_t v = 0; v < mesh.normals.size(); ++v)
                if (mesh.normals[v] == Vec3{0, 0, 0}) mesh.normals[v] = computed.normals[v];
        }
    } else if (options.computeMissingNormals) {
        if (nonFinite == 0) recomputeNormals(mesh);
    }
    if (infoOut) *infoOut = std::move(info);
    return mesh;
}

}  // namespace mucosa::mesh
