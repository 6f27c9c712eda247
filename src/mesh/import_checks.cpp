#include "import_checks.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>

#include "core/json_parse.hpp"

namespace mucosa::mesh::detail {

namespace fs = std::filesystem;
using nlohmann::json;

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

namespace {

// A non-negative whole JSON number that fits in 2^53, or `fallback` when absent.
std::uint64_t count(const json& object, const char* key, const fs::path& path, const std::string& where,
                    std::uint64_t fallback = 0) {
    const auto it = object.find(key);
    if (it == object.end()) return fallback;
    return mucosa::detail::wholeNumber<std::uint64_t>(*it, where + "." + key, path.string(), 0, 1ull << 53);
}

std::uint64_t componentBytes(std::uint64_t type) {
    switch (type) {
        case 5120:
        case 5121:
            return 1;
        case 5122:
        case 5123:
            return 2;
        case 5125:
        case 5126:
            return 4;
        default:
            return 0;
    }
}

std::uint64_t componentsOf(const std::string& type) {
    if (type == "SCALAR") return 1;
    if (type == "VEC2") return 2;
    if (type == "VEC3") return 3;
    if (type == "VEC4" || type == "MAT2") return 4;
    if (type == "MAT3") return 9;
    if (type == "MAT4") return 16;
    return 0;
}

}  // namespace

std::string percentDecoded(const std::string& s) {
    std::string out;
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
            std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
            out += static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
            i += 2;
        } else {
            out += s[i];
        }
    }
    return out;
}

bool insideFolder(const fs::path& folder, const std::string& reference) {
    return confinedPath(folder, percentDecoded(reference)).has_value();
}

void checkGltf(const fs::path& path, bool binary, std::uintmax_t fileBytes) {
    const std::string name = path.string();
    std::ifstream in(path, std::ios::binary);
    std::string text;
    std::uint64_t binBytes = 0;
    bool hasBin = false;
    if (binary) {
        char header[12];
        if (!in.read(header, 12)) throw InputError("GLB", name, "shorter than the 12-byte GLB header");
        std::uint32_t magic, version, length;
        std::memcpy(&magic, header, 4);
        std::memcpy(&version, header + 4, 4);
        std::memcpy(&length, header + 8, 4);
        if (magic != 0x46546C67u) throw InputError("GLB", name, "no glTF magic at the start");
        if (version != 2) throw InputError("GLB", name, fmt::format("container version {} (only 2 is read)", version));
        if (length > fileBytes)
            throw InputError("GLB", name,
                             fmt::format("header declares {} bytes but the file has {}", length, fileBytes));
        std::uint64_t at = 12;
        for (int chunk = 0; at + 8 <= length; ++chunk) {
            char ch[8];
            in.seekg(static_cast<std::streamoff>(at));
            if (!in.read(ch, 8)) break;
            std::uint32_t chunkLength, chunkType;
            std::memcpy(&chunkLength, ch, 4);
            std::memcpy(&chunkType, ch + 4, 4);
            if (chunkLength > length - at - 8)
                throw InputError("GLB", name,
                                 fmt::format("chunk {} declares {} bytes but only {} follow it", chunk, chunkLength,
                                             length - at - 8));
            if (chunk == 0) {
                if (chunkType != 0x4E4F534Au) throw InputError("GLB", name, "the first chunk is not JSON");
                text.resize(chunkLength);
                in.read(text.data(), chunkLength);
            } else if (chunk == 1 && chunkType == 0x004E4942u) {
                hasBin = true;
                binBytes = chunkLength;
            }
            at += 8 + ((std::uint64_t(chunkLength) + 3) & ~std::uint64_t(3));
        }
        if (text.empty()) throw InputError("GLB", name, "no JSON chunk");
    } else {
        text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    const json doc = mucosa::detail::parseJsonFile(text, name);
    if (!doc.is_object()) throw InputError("glTF", name, "the document is not a JSON object");
    const fs::path folder = path.parent_path();
    auto arrayOf = [&](const char* key) -> const json& {
        static const json empty = json::array();
        const auto it = doc.find(key);
        if (it == doc.end()) return empty;
        if (!it->is_array()) throw InputError("glTF", name, fmt::format("'{}' is not an array", key));
        return *it;
    };
    auto confined = [&](const json& uri, const std::string& where) {
        if (!uri.is_string()) throw InputError("glTF", name, fmt::format("{}.uri is not a string", where));
        const std::string u = uri.get<std::string>();
        if (u.rfind("data:", 0) == 0) return;
        if (!insideFolder(folder, u))
            throw InputError("glTF", name,
                             fmt::format("{}.uri '{}' is not a file inside the model's folder (only relative paths "
                                         "below it and data: URIs are read)",
                                         where, u.substr(0, 200)));
    };

    std::vector<std::uint64_t> bufferBytes;
    const json& buffers = arrayOf("buffers");
    for (std::size_t i = 0; i < buffers.size(); ++i) {
        const json& b = buffers[i];
        const std::string where = fmt::format("buffers[{}]", i);
        if (!b.is_object()) throw InputError("glTF", name, where + " is not an object");
        const std::uint64_t bytes = count(b, "byteLength", path, where);
        std::uint64_t backed = 0;
        if (const auto uri = b.find("uri"); uri != b.end()) {
            confined(*uri, where);
            const std::string u = uri->get<std::string>();
            if (u.rfind("data:", 0) == 0) {
                const auto comma = u.find(',');
                const std::uint64_t payload = comma == std::string::npos ? 0 : u.size() - comma - 1;
                backed = u.find(";base64,") != std::string::npos ? payload / 4 * 3 + 3 : payload;
            } else {
                std::error_code ec;
                backed = fs::file_size(folder / percentDecoded(u), ec);
                if (ec)
                    throw InputError("glTF", name,
                                     fmt::format("{}.uri '{}': {}", where, u.substr(0, 200), ec.message()));
            }
        } else if (i == 0 && hasBin) {
            backed = binBytes;
        }
        if (bytes > backed)
            throw InputError("glTF", name,
                             fmt::format("{} declares {} bytes but only {} back it", where, bytes, backed));
        bufferBytes.push_back(bytes);
    }
    for (std::size_t i = 0; const json& image : arrayOf("images")) {
        if (image.is_object() && image.contains("uri")) confined(image["uri"], fmt::format("images[{}]", i));
        ++i;
    }

    struct View {
        std::uint64_t bytes, stride;
    };
    std::vector<View> views;
    const json& bufferViews = arrayOf("bufferViews");
    for (std::size_t i = 0; i < bufferViews.size(); ++i) {
        const json& v = bufferViews[i];
        const std::string where = fmt::format("bufferViews[{}]", i);
        if (!v.is_object()) throw InputError("glTF", name, where + " is not an object");
        const std::uint64_t buffer = count(v, "buffer", path, where);
        const std::uint64_t offset = count(v, "byteOffset", path, where);
        const std::uint64_t bytes = count(v, "byteLength", path, where);
        if (buffer >= bufferBytes.size())
            throw InputError("glTF", name, fmt::format("{}.buffer {} does not exist", where, buffer));
        if (offset + bytes > bufferBytes[buffer])
            throw InputError(
                "glTF", name,
                fmt::format("{} ends at byte {} of a {}-byte buffer", where, offset + bytes, bufferBytes[buffer]));
        views.push_back({bytes, count(v, "byteStride", path, where)});
    }

    // Accessors without a buffer view are zero-filled by the importer: bound them
    // so a few bytes of JSON cannot ask for gigabytes.
    const std::uint64_t zeroFilledBudget = std::max<std::uint64_t>(64ull << 20, 64 * std::uint64_t(fileBytes));
    std::uint64_t zeroFilled = 0;
    const json& accessors = arrayOf("accessors");
    for (std::size_t i = 0; i < accessors.size(); ++i) {
        const json& a = accessors[i];
        const std::string where = fmt::format("accessors[{}]", i);
        if (!a.is_object()) throw InputError("glTF", name, where + " is not an object");
        const std::uint64_t n = count(a, "count", path, where);
        const std::uint64_t component = componentBytes(count(a, "componentType", path, where));
        const std::uint64_t components =
            a.contains("type") && a["type"].is_string() ? componentsOf(a["type"].get<std::string>()) : 0;
        if (component == 0 || components == 0)
            throw InputError("glTF", name, fmt::format("{} has an unknown componentType or type", where));
        const std::uint64_t element = component * components;
        if (a.contains("bufferView")) {
            const std::uint64_t view = count(a, "bufferView", path, where);
            if (view >= views.size())
                throw InputError("glTF", name, fmt::format("{}.bufferView {} does not exist", where, view));
            const std::uint64_t offset = count(a, "byteOffset", path, where);
            const std::uint64_t stride = views[view].stride ? views[view].stride : element;
            const std::uint64_t end = n == 0 ? offset : offset + (n - 1) * stride + element;
            if (end > views[view].bytes)
                throw InputError("glTF", name,
                                 fmt::format("{} ({} elements) ends at byte {} of a {}-byte buffer view", where, n, end,
                                             views[view].bytes));
        } else {
            zeroFilled += n * element;
            if (zeroFilled > zeroFilledBudget)
                throw InputError(
                    "glTF", name,
                    fmt::format("accessors without data ask for {} (more than {} for a {} file)",
                                formatBytes(zeroFilled), formatBytes(zeroFilledBudget), formatBytes(fileBytes)));
        }
        if (const auto sparse = a.find("sparse"); sparse != a.end() && sparse->is_object())
            if (count(*sparse, "count", path, where + ".sparse") > n)
                throw InputError("glTF", name, fmt::format("{}.sparse.count exceeds the accessor's count", where));
    }
}

}  // namespace mucosa::mesh::detail
