#pragma once
// Reading any mesh format Assimp understands into a Mesh (millimetres, good
// normals), and writing glTF 2.0 (.glb/.gltf), PLY and OBJ.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh {

// The length unit of the coordinates in a file. glTF fixes metres; OBJ, PLY
// and STL carry no unit, so Auto guesses from the size (see LoadInfo::unitReason).
enum class Unit { Auto, Millimetres, Centimetres, Metres, Inches };

// Parses "auto", "mm", "cm", "m", "in" (InputError otherwise).
Unit parseUnit(const std::string& text);
double millimetresPer(Unit unit) noexcept;  // 1, 10, 1000, 25.4 (Auto: 1)

struct LoadOptions {
    Unit unit = Unit::Auto;
    // Non-finite coordinates are refused (InputError) unless this is set; then
    // they are kept and counted (mucosa mesh info inspects broken files).
    bool allowNonFinite = false;
    // Compute angle-weighted normals where the file has none (or zero ones).
    bool computeMissingNormals = true;
    // Assimp parses the file in a child process (fork) with these limits, so a
    // crash, hang or memory exhaustion inside it becomes an InputError. 0 =
    // scaled to the file (memory: 40x its size, at least 512 MiB, at most half
    // of what is available; CPU: 10 s + 1 s per MiB, whole seconds; wall clock:
    // 2x CPU + 5 s).
    std::uint64_t importMemoryBytes = 0;
    double importSeconds = 0;
    // false parses in the calling process (for debugging the importer only:
    // then a hostile file can crash or hang the caller).
    bool isolate = true;
};

// What the importer found and did, for reports.
struct LoadInfo {
    std::string format;  // Assimp's importer ("glTF2 Importer", ...)
    std::size_t fileBytes = 0;
    std::size_t subMeshes = 0;          // triangle meshes merged into one
    std::size_t droppedPrimitives = 0;  // points/lines ignored
    double scaleToMillimetres = 1;
    std::string unitReason;  // "glTF is in metres", "assumed millimetres: ..."
    std::string upAxis;      // "+Y (glTF)" or "as stored in the file"
    bool fileHadNormals = false, fileHadUvs = false, fileHadTangents = false;
    bool fileHadColors = false;  // vertex colours (the first set: glTF COLOR_0, PLY red/green/blue, OBJ v x y z r g b)
    // glTF: the file's materials as the importer counted them; Mesh::materials
    // then holds each triangle's index into them (kNoMaterial: none). Other
    // formats: 0, and Mesh::materials is empty.
    std::size_t fileMaterials = 0;
    std::size_t repairedNormals = 0;  // zero/non-finite normals recomputed
    std::vector<std::string> warnings;
};

// Loads and merges every triangle mesh of the file (node transforms applied),
// scaled to millimetres. UVs come out in OpenGL's convention (Assimp flips glTF's
// v on import; nothing is flipped twice). Tangents, when the file has them,
// keep the file's handedness w. Throws IoError (missing/unreadable) or
// InputError (unsupported, no triangles, bad indices, non-finite values, sizes
// that cannot be real) naming the file; refuses absurd sizes before allocating.
Mesh load(const std::filesystem::path& path, const LoadOptions& options = {}, LoadInfo* info = nullptr);

// Whether load() reads files with `path`'s extension (case-insensitive: any
// format Assimp imports, .obj .ply .stl .gltf .glb .fbx ...). The file itself
// is not opened.
bool isMeshFile(const std::filesystem::path& path);

enum class FileFormat { Glb, Gltf, Ply, Obj };
// From the extension (.glb, .gltf, .ply, .obj); InputError otherwise.
FileFormat outputFormat(const std::filesystem::path& path);

struct GltfLook;

struct SaveOptions {
    std::string name = "mucosa";  // node/mesh name in glTF, comment in PLY/OBJ
    // glTF: the materials, textures, samplers and images to write
    // (<mucosa/mesh/gltf.hpp>); Mesh::materials indexes look->materials (empty:
    // every triangle has material 0). One primitive per material, sharing the
    // vertex arrays; a primitive's TANGENT only where its material reads a
    // normal texture (normalTexture, clearcoatNormalTexture, anisotropyTexture:
    // nothing the Khronos validator calls unused). Images: bufferViews of the
    // binary chunk in .glb, data URIs in .gltf. null: one untextured
    // material, every attribute written. PLY and OBJ ignore it.
    const GltfLook* look = nullptr;
};

// Writes atomically (a temporary next to `path`, renamed when complete).
// glTF: positions in metres (the format's unit), v flipped to glTF's top-left
// origin, POSITION min/max, unit NORMAL, TANGENT xyz unit with w = +-1;
// .gltf embeds its buffer (and images) as base64 data URIs (one file, one
// atomic rename).
// PLY (binary little-endian) and OBJ: millimetres, OpenGL UVs.
void save(const Mesh& mesh, const std::filesystem::path& path, const SaveOptions& options = {});
void writeGltf(const Mesh& mesh, const std::filesystem::path& path, bool binary, const SaveOptions& options = {});
void writePly(const Mesh& mesh, const std::filesystem::path& path, const SaveOptions& options = {});
void writeObj(const Mesh& mesh, const std::filesystem::path& path, const SaveOptions& options = {});

// Throws InputError if indices are out of range, the index count is not a
// multiple of 3, or attribute arrays disagree in length with the positions.
void validateIndices(const Mesh& mesh, const std::string& nameForErrors = {});

}  // namespace mucosa::mesh
