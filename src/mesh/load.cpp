// Import through Assimp: every format it reads, merged into one Mesh in mm.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include <assimp/importerdesc.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <assimp/Importer.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/repair.hpp>

#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;

namespace {

std::string lowerExtension(const std::filesystem::path& p) {
    std::string e = p.extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return e;
}

// Sizes a file declares before its data (PLY element counts, binary STL's
// triangle count) checked against the file's size, so a lying header is refused
// before an importer reserves memory for it.
void checkDeclaredSizes(const std::filesystem::path& path, const std::string& ext, std::uintmax_t fileBytes) {
    std::ifstream in(path, std::ios::binary);
    // Assimp picks an importer by content when the extension's refuses the
    // file, so PLY bytes under another name (x.gltf) reach its PLY reader too:
    // the PLY checks go by the magic as well as by the extension.
    char magic[4] = {};
    in.read(magic, 4);
    in.clear();
    in.seekg(0);
    const bool plyMagic = std::strncmp(magic, "ply", 3) == 0 && (magic[3] == '\n' || magic[3] == '\r');
    if (ext == ".ply" || plyMagic) {
        // The header is read from a bounded prefix only: Assimp 5.2.5 hangs (and
        // ignores SIGTERM) or crashes on a header without end_header, so such a
        // file is refused here, never handed to it.
        constexpr std::size_t maxHeaderBytes = 1 << 20;
        std::string head(static_cast<std::size_t>(std::min<std::uintmax_t>(fileBytes, maxHeaderBytes)), '\0');
        in.read(head.data(), static_cast<std::streamsize>(head.size()));
        head.resize(static_cast<std::size_t>(std::max<std::streamsize>(in.gcount(), 0)));
        std::istringstream headIn(head);
        std::string line, format;
        std::uint64_t declared = 0;
        bool ended = false;
        for (int i = 0; i < 10000 && std::getline(headIn, line); ++i) {
            if (line.rfind("format", 0) == 0) format = line;
            unsigned long long count = 0;
            char name[64] = {};
            if (std::sscanf(line.c_str(), "element %63s %llu", name, &count) == 2) {
                if (count > std::numeric_limits<std::uint64_t>::max() / 4 - declared)
                    throw InputError("PLY header", path.string(), "element count overflows");
                declared += count;
            }
            if (line.rfind("end_header", 0) == 0) {
                ended = true;
                break;
            }
        }
        if (!ended)
            throw InputError("PLY header", path.string(),
                             fmt::format("no end_header line within the first {} bytes or 10000 lines",
                                         std::min<std::uintmax_t>(fileBytes, maxHeaderBytes)));
        // Every element takes at least one byte (binary) or two characters (ASCII).
        const std::uint64_t minBytes = format.find("ascii") != std::string::npos ? 2 * declared : declared;
        if (minBytes > fileBytes)
            throw InputError("PLY header", path.string(),
                             fmt::format("declares {} elements but the file has only {} bytes", declared, fileBytes));
        requireMemory(saturatingMul(declared, 64), fmt::format("mesh '{}'", path.string()));
    } else if (ext == ".stl") {
        char head[84] = {};
        in.read(head, 84);
        if (in.gcount() == 84 && std::strncmp(head, "solid", 5) != 0) {
            std::uint32_t count = 0;
            std::memcpy(&count, head + 80, 4);
            if (84 + 50ull * count != fileBytes)
                throw InputError("STL header", path.string(),
                                 fmt::format("declares {} triangles ({} bytes) but the file has {} bytes", count,
                                             84 + 50ull * count, fileBytes));
        }
    }
}

}  // namespace

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
    Assimp::Importer importer;
    if (ext.empty() || !importer.IsExtensionSupported(ext))
        throw InputError("mesh", name, fmt::format("unsupported format '{}'", ext.empty() ? "(no extension)" : ext));
    checkDeclaredSizes(path, ext, fileBytes);
    // Parsers hold the file and the scene at once: refuse up front what cannot fit.
    requireMemory(saturatingMul(fileBytes, 6), fmt::format("importing '{}'", name));

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
    if (!scene) {
        std::string why = importer.GetErrorString();
        if (why.empty()) why = "the importer could not read it";
        throw InputError("mesh", name, why);
    }

    if (const aiImporterDesc* d = importer.GetImporterInfo(importer.GetImporterIndex(ext.c_str())))
        info.format = d->mName;

    // Count first, check memory, then copy.
    std::size_t vertices = 0, triangles = 0;
    bool allNormals = true, allUvs = true, allTangents = true;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const aiMesh* am = scene->mMeshes[m];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) {
            ++info.droppedPrimitives;
            continue;
        }
        ++info.subMeshes;
        vertices += am->mNumVertices;
        triangles += am->mNumFaces;
        allNormals = allNormals && am->HasNormals();
        allUvs = allUvs && am->HasTextureCoords(0);
        allTangents = allTangents && am->HasTangentsAndBitangents() && am->HasNormals();
    }
    if (triangles == 0) throw InputError("mesh", name, "the file contains no triangles");
    if (vertices > std::numeric_limits<std::uint32_t>::max() - 1 ||
        triangles > std::numeric_limits<std::uint32_t>::max() / 3)
        throw InputError("mesh", name,
                         fmt::format("{} vertices / {} triangles exceed 32-bit indices", vertices, triangles));
    requireMemory(
        saturatingMul(vertices, sizeof(Vec3) * 2 + sizeof(Vec2) + sizeof(Vec4)) + saturatingMul(triangles, 12),
        fmt::format("mesh '{}'", name));
    info.fileHadNormals = allNormals;
    info.fileHadUvs = allUvs;
    info.fileHadTangents = allTangents;
    if (info.subMeshes > 1) {
        std::size_t anyUv = 0;
        for (unsigned m = 0; m < scene->mNumMeshes; ++m) anyUv += scene->mMeshes[m]->HasTextureCoords(0) ? 1 : 0;
        if (!allUvs && anyUv > 0)
            info.warnings.push_back("some parts have texture coordinates and some not: all dropped");
    }

    Mesh mesh;
    mesh.positions.reserve(vertices);
    mesh.indices.reserve(3 * triangles);
    if (allNormals) mesh.normals.reserve(vertices);
    if (allUvs) mesh.uvs.reserve(vertices);
    if (allTangents) mesh.tangents.reserve(vertices);
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
        }
    }
    if (mesh.indices.empty()) throw InputError("mesh", name, "the file contains no triangles");

    // Units.
    double scale = 1.0;
    const bool gltf = ext == ".gltf" || ext == ".glb";
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
