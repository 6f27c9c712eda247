#include <mucosa/mesh/io.hpp>

#include <algorithm>
#include <cctype>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>

namespace mucosa::mesh {

Unit parseUnit(const std::string& text) {
    if (text == "auto") return Unit::Auto;
    if (text == "mm") return Unit::Millimetres;
    if (text == "cm") return Unit::Centimetres;
    if (text == "m") return Unit::Metres;
    if (text == "in") return Unit::Inches;
    throw InputError("unit", "", fmt::format("'{}' is not one of auto, mm, cm, m, in", text));
}

double millimetresPer(Unit unit) noexcept {
    switch (unit) {
        case Unit::Centimetres:
            return 10.0;
        case Unit::Metres:
            return 1000.0;
        case Unit::Inches:
            return 25.4;
        default:
            return 1.0;
    }
}

FileFormat outputFormat(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".glb") return FileFormat::Glb;
    if (ext == ".gltf") return FileFormat::Gltf;
    if (ext == ".ply") return FileFormat::Ply;
    if (ext == ".obj") return FileFormat::Obj;
    throw InputError("output format", path.string(), "unsupported extension (write .glb, .gltf, .ply or .obj)");
}

void validateIndices(const Mesh& mesh, const std::string& name) {
    const std::size_t n = mesh.vertexCount();
    if (mesh.indices.size() % 3 != 0)
        throw InputError("indices", name,
                         fmt::format("{} indices is not a whole number of triangles", mesh.indices.size()));
    auto attr = [&](std::size_t size, const char* what) {
        if (size != 0 && size != n) throw InputError(what, name, fmt::format("{} values for {} vertices", size, n));
    };
    attr(mesh.normals.size(), "normals");
    attr(mesh.uvs.size(), "texture coordinates");
    attr(mesh.tangents.size(), "tangents");
    if (!mesh.materials.empty() && mesh.materials.size() != mesh.triangleCount())
        throw InputError(
            "materials", name,
            fmt::format("{} per-triangle materials for {} triangles", mesh.materials.size(), mesh.triangleCount()));
    const auto it = std::find_if(mesh.indices.begin(), mesh.indices.end(), [n](std::uint32_t i) { return i >= n; });
    if (it != mesh.indices.end())
        throw InputError(
            "indices", name,
            fmt::format("index {} at position {} is out of range ({} vertices)", *it, it - mesh.indices.begin(), n));
}

void save(const Mesh& mesh, const std::filesystem::path& path, const SaveOptions& options) {
    switch (outputFormat(path)) {
        case FileFormat::Glb:
            writeGltf(mesh, path, true, options);
            break;
        case FileFormat::Gltf:
            writeGltf(mesh, path, false, options);
            break;
        case FileFormat::Ply:
            writePly(mesh, path, options);
            break;
        case FileFormat::Obj:
            writeObj(mesh, path, options);
            break;
    }
}

}  // namespace mucosa::mesh
