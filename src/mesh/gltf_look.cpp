// A glTF file's look (materials, textures, samplers, images) read straight
// from its JSON and binary chunk, and pruned to what a mesh still uses.
#include <algorithm>
#include <cstring>
#include <map>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/mesh/gltf.hpp>

#include "core/json_parse.hpp"
#include "import_checks.hpp"

namespace mucosa::mesh {

namespace {

using json = nlohmann::json;

constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A, kChunkBin = 0x004E4942;

std::uint32_t u32(const std::vector<std::byte>& b, std::size_t at) {
    std::uint32_t v;
    std::memcpy(&v, b.data() + at, 4);
    return v;
}

int base64Value(char c) {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
}

// RFC 4648 base64 (padding optional); nullopt-like empty + ok=false on bad input.
bool decodeBase64(std::string_view text, std::vector<std::uint8_t>& out) {
    out.clear();
    out.reserve(text.size() / 4 * 3);
    std::uint32_t acc = 0;
    int bits = 0;
    std::size_t i = 0;
    for (; i < text.size() && text[i] != '='; ++i) {
        const int v = base64Value(text[i]);
        if (v < 0) return false;
        acc = (acc << 6) | static_cast<std::uint32_t>(v);
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            out.push_back(static_cast<std::uint8_t>((acc >> bits) & 0xFF));
        }
    }
    for (; i < text.size(); ++i)
        if (text[i] != '=') return false;
    return true;
}

class Source {
public:
    explicit Source(const std::filesystem::path& path) : path_(path), name_(path.string()) {
        const std::vector<std::byte> bytes = readFile(path);
        if (bytes.size() >= 4 && u32(bytes, 0) == kGlbMagic) {
            if (bytes.size() < 20) fail("file", "truncated GLB header");
            if (u32(bytes, 4) != 2) fail("file", fmt::format("GLB version {} (glTF 2.0 needs 2)", u32(bytes, 4)));
            const std::size_t total = std::min<std::size_t>(u32(bytes, 8), bytes.size());
            std::size_t at = 12;
            bool first = true;
            std::string text;
            while (at + 8 <= total) {
                const std::size_t len = u32(bytes, at), type = u32(bytes, at + 4);
                if (len > total - at - 8) fail("file", "a GLB chunk runs past the end of the file");
                const auto* p = reinterpret_cast<const char*>(bytes.data() + at + 8);
                if (first && type != kChunkJson) fail("file", "the first GLB chunk is not JSON");
                if (first) text.assign(p, len);
                if (!first && type == kChunkBin && !haveBin_) {
                    bin_.assign(reinterpret_cast<const std::uint8_t*>(p),
                                reinterpret_cast<const std::uint8_t*>(p) + len);
                    haveBin_ = true;
                }
                first = false;
                at += 8 + ((len + 3) & ~std::size_t(3));  // chunks are 4-byte aligned
            }
            if (first) fail("file", "a GLB without a JSON chunk");
            parse(text);
        } else {
            parse(std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
        }
        if (!doc_.is_object()) fail("file", "the glTF JSON is not an object");
        if (!doc_.contains("asset") || !doc_["asset"].is_object() || doc_["asset"].value("version", "") != "2.0")
            fail("asset.version", "not glTF 2.0");
    }

    const json& doc() const { return doc_; }

    const json& array(const char* key) const {
        static const json empty = json::array();
        if (!doc_.contains(key)) return empty;
        if (!doc_[key].is_array()) fail(key, "is not an array");
        return doc_[key];
    }

    std::size_t index(const json& v, std::size_t count, const std::string& field) const {
        if (!v.is_number_unsigned() || v.get<std::uint64_t>() >= count)
            fail(field, fmt::format("index {} is out of range ({} defined)", v.dump(), count));
        return v.get<std::size_t>();
    }

    // The bytes of image i.
    std::vector<std::uint8_t> imageBytes(const json& image, std::size_t i) {
        const std::string field = fmt::format("images[{}]", i);
        if (image.contains("uri")) return uriBytes(image["uri"], field + ".uri");
        if (!image.contains("bufferView")) fail(field, "has neither uri nor bufferView");
        const json& views = array("bufferViews");
        const json& view = views[index(image["bufferView"], views.size(), field + ".bufferView")];
        const std::string vf = fmt::format("bufferViews[{}]", image["bufferView"].get<std::size_t>());
        if (!view.is_object()) fail(vf, "is not an object");
        const json& buffers = array("buffers");
        const std::size_t b = index(view.value("buffer", json()), buffers.size(), vf + ".buffer");
        const std::vector<std::uint8_t>& data = buffer(b);
        const json off = view.value("byteOffset", json(0)), len = view.value("byteLength", json());
        if (!off.is_number_unsigned() || !len.is_number_unsigned())
            fail(vf, "byteOffset/byteLength missing or negative");
        const std::uint64_t o = off.get<std::uint64_t>(), n = len.get<std::uint64_t>();
        if (o > data.size() || n > data.size() - o)
            fail(vf, fmt::format("bytes {}..{} lie outside buffer {} ({} bytes)", o, o + n, b, data.size()));
        return {data.begin() + static_cast<std::ptrdiff_t>(o), data.begin() + static_cast<std::ptrdiff_t>(o + n)};
    }

    [[noreturn]] void fail(const std::string& what, const std::string& why) const {
        throw InputError(what, name_, why);
    }

private:
    void parse(const std::string& text) { doc_ = mucosa::detail::parseJsonFile(text, name_); }

    const std::vector<std::uint8_t>& buffer(std::size_t b) {
        auto it = buffers_.find(b);
        if (it != buffers_.end()) return it->second;
        const json& buf = array("buffers")[b];
        const std::string field = fmt::format("buffers[{}]", b);
        std::vector<std::uint8_t> data;
        if (buf.is_object() && buf.contains("uri"))
            data = uriBytes(buf["uri"], field + ".uri");
        else if (b == 0 && haveBin_)
            data = bin_;
        else
            fail(field, "has no uri and the file has no binary chunk");
        return buffers_.emplace(b, std::move(data)).first->second;
    }

    std::vector<std::uint8_t> uriBytes(const json& uri, const std::string& field) {
        if (!uri.is_string()) fail(field, "is not a string");
        const std::string u = uri.get<std::string>();
        if (u.rfind("data:", 0) == 0) {
            const std::size_t comma = u.find(',');
            if (comma == std::string::npos || u.substr(0, comma).find(";base64") == std::string::npos)
                fail(field, "a data URI that is not base64");
            std::vector<std::uint8_t> out;
            if (!decodeBase64(std::string_view(u).substr(comma + 1), out)) fail(field, "malformed base64");
            return out;
        }
        const auto p = confinedPath(path_.parent_path(), detail::percentDecoded(u));
        if (!p) fail(field, fmt::format("'{}' is not a file beside the model", u));
        if (!std::filesystem::exists(*p)) fail(field, fmt::format("{} does not exist", p->string()));
        const std::vector<std::byte> b = readFile(*p);
        return {reinterpret_cast<const std::uint8_t*>(b.data()),
                reinterpret_cast<const std::uint8_t*>(b.data()) + b.size()};
    }

    std::filesystem::path path_;
    std::string name_;
    json doc_;
    std::vector<std::uint8_t> bin_;
    bool haveBin_ = false;
    std::map<std::size_t, std::vector<std::uint8_t>> buffers_;
};

std::string sniffMime(const std::vector<std::uint8_t>& b) {
    if (b.size() >= 8 && b[0] == 0x89 && b[1] == 'P' && b[2] == 'N' && b[3] == 'G') return "image/png";
    if (b.size() >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) return "image/jpeg";
    return {};
}

bool endsWith(const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// Calls f(textureInfo) for every texture reference inside a material.
template <class F>
void forEachTextureInfo(json& j, F&& f) {
    if (j.is_object()) {
        for (auto it = j.begin(); it != j.end(); ++it) {
            if (endsWith(it.key(), "Texture") && it.value().is_object() && it.value().contains("index")) f(it.value());
            forEachTextureInfo(it.value(), f);
        }
    } else if (j.is_array()) {
        for (json& e : j) forEachTextureInfo(e, f);
    }
}

// Calls f(sourceRef) for a texture's image references ("source", and any
// extension's "source": KHR_texture_basisu, EXT_texture_webp, ...).
template <class F>
void forEachImageRef(json& texture, F&& f) {
    if (texture.contains("source")) f(texture["source"]);
    if (texture.contains("extensions") && texture["extensions"].is_object())
        for (auto& [name, ext] : texture["extensions"].items())
            if (ext.is_object() && ext.contains("source")) f(ext["source"]);
}

// The walks below recurse into the kept JSON: a hostile file's nesting is
// bounded first (iteratively), so they cannot exhaust the stack.
constexpr int kMaxDepth = 64;

int depthOf(const json& root) {
    int deepest = 0;
    std::vector<std::pair<const json*, int>> stack{{&root, 1}};
    while (!stack.empty()) {
        const auto [j, d] = stack.back();
        stack.pop_back();
        deepest = std::max(deepest, d);
        if (d > kMaxDepth) return d;
        if (j->is_structured())
            for (auto it = j->begin(); it != j->end(); ++it) stack.push_back({&*it, d + 1});
    }
    return deepest;
}

}  // namespace

void collectExtensions(const json& j, std::vector<std::string>& names) {
    if (j.is_object()) {
        for (auto it = j.begin(); it != j.end(); ++it) {
            if (it.key() == "extensions" && it.value().is_object())
                for (auto e = it.value().begin(); e != it.value().end(); ++e)
                    if (std::find(names.begin(), names.end(), e.key()) == names.end()) names.push_back(e.key());
            collectExtensions(it.value(), names);
        }
    } else if (j.is_array()) {
        for (const json& e : j) collectExtensions(e, names);
    }
}

GltfLook readGltfLook(const std::filesystem::path& path) {
    Source src(path);
    // Bounded before anything is copied: copying a json recurses too.
    for (const char* key : {"materials", "textures", "samplers", "images"})
        if (depthOf(src.array(key)) > kMaxDepth) src.fail(key, fmt::format("nested deeper than {} levels", kMaxDepth));
    GltfLook look;
    look.materials = src.array("materials");
    look.textures = src.array("textures");
    look.samplers = src.array("samplers");
    const json& images = src.array("images");
    // Every reference checked here, so the writer never writes a dangling one.
    for (std::size_t m = 0; m < look.materials.size(); ++m) {
        if (!look.materials[m].is_object()) src.fail(fmt::format("materials[{}]", m), "is not an object");
        forEachTextureInfo(look.materials[m], [&](json& info) {
            src.index(info["index"], look.textures.size(), fmt::format("materials[{}] texture index", m));
        });
    }
    for (std::size_t t = 0; t < look.textures.size(); ++t) {
        const std::string field = fmt::format("textures[{}]", t);
        if (!look.textures[t].is_object()) src.fail(field, "is not an object");
        if (look.textures[t].contains("sampler"))
            src.index(look.textures[t]["sampler"], look.samplers.size(), field + ".sampler");
        forEachImageRef(look.textures[t], [&](json& ref) { src.index(ref, images.size(), field + ".source"); });
    }
    for (std::size_t i = 0; i < images.size(); ++i) {
        if (!images[i].is_object()) src.fail(fmt::format("images[{}]", i), "is not an object");
        std::vector<std::uint8_t> bytes = src.imageBytes(images[i], i);
        json image = images[i];
        image.erase("uri");
        image.erase("bufferView");
        if (!image.contains("mimeType")) {
            const std::string mime = sniffMime(bytes);
            if (mime.empty()) src.fail(fmt::format("images[{}]", i), "neither PNG nor JPEG and no mimeType");
            image["mimeType"] = mime;
        }
        look.images.push_back(std::move(image));
        look.imageData.push_back(std::move(bytes));
    }
    if (src.doc().contains("extensionsRequired") && src.doc()["extensionsRequired"].is_array())
        for (const json& e : src.doc()["extensionsRequired"])
            if (e.is_string()) look.extensionsRequired.push_back(e.get<std::string>());
    return look;
}

std::vector<std::uint32_t> pruneGltfLook(GltfLook& look, const std::vector<bool>& materialUsed) {
    const std::size_t nm = look.materials.size(), nt = look.textures.size(), ni = look.images.size(),
                      ns = look.samplers.size();
    std::vector<std::uint32_t> materialMap(nm, kNoMaterial), textureMap(nt, kNoMaterial), imageMap(ni, kNoMaterial),
        samplerMap(ns, kNoMaterial);
    json materials = json::array();
    for (std::size_t m = 0; m < nm; ++m) {
        if (m >= materialUsed.size() || !materialUsed[m]) continue;
        materialMap[m] = static_cast<std::uint32_t>(materials.size());
        materials.push_back(look.materials[m]);
    }
    // Reached textures, images and samplers, in their old order.
    std::vector<bool> texUsed(nt, false), imgUsed(ni, false), smpUsed(ns, false);
    for (json& m : materials)
        forEachTextureInfo(m, [&](json& info) { texUsed[info["index"].get<std::size_t>()] = true; });
    for (std::size_t t = 0; t < nt; ++t) {
        if (!texUsed[t]) continue;
        if (look.textures[t].contains("sampler")) smpUsed[look.textures[t]["sampler"].get<std::size_t>()] = true;
        forEachImageRef(look.textures[t], [&](json& ref) { imgUsed[ref.get<std::size_t>()] = true; });
    }
    auto number = [](const std::vector<bool>& used, std::vector<std::uint32_t>& map) {
        std::uint32_t next = 0;
        for (std::size_t i = 0; i < used.size(); ++i)
            if (used[i]) map[i] = next++;
    };
    number(texUsed, textureMap);
    number(imgUsed, imageMap);
    number(smpUsed, samplerMap);
    const bool identity = materials.size() == nm &&
                          std::all_of(texUsed.begin(), texUsed.end(), [](bool b) { return b; }) &&
                          std::all_of(imgUsed.begin(), imgUsed.end(), [](bool b) { return b; }) &&
                          std::all_of(smpUsed.begin(), smpUsed.end(), [](bool b) { return b; });
    if (identity) return materialMap;

    for (json& m : materials)
        forEachTextureInfo(m, [&](json& info) { info["index"] = textureMap[info["index"].get<std::size_t>()]; });
    json textures = json::array(), images = json::array(), samplers = json::array();
    for (std::size_t t = 0; t < nt; ++t) {
        if (!texUsed[t]) continue;
        json tex = look.textures[t];
        if (tex.contains("sampler")) tex["sampler"] = samplerMap[tex["sampler"].get<std::size_t>()];
        forEachImageRef(tex, [&](json& ref) { ref = imageMap[ref.get<std::size_t>()]; });
        textures.push_back(std::move(tex));
    }
    std::vector<std::vector<std::uint8_t>> data;
    for (std::size_t i = 0; i < ni; ++i)
        if (imgUsed[i]) {
            images.push_back(look.images[i]);
            data.push_back(std::move(look.imageData[i]));
        }
    for (std::size_t s = 0; s < ns; ++s)
        if (smpUsed[s]) samplers.push_back(look.samplers[s]);
    look.materials = std::move(materials);
    look.textures = std::move(textures);
    look.images = std::move(images);
    look.samplers = std::move(samplers);
    look.imageData = std::move(data);
    return materialMap;
}

bool readsTexture(const json& material) {
    bool any = false;
    json copy = material;
    forEachTextureInfo(copy, [&](json&) { any = true; });
    return any;
}

int maxTexCoord(const GltfLook& look) {
    int highest = -1;
    json materials = look.materials;
    for (json& m : materials)
        forEachTextureInfo(m, [&](json& info) {
            int set = 0;
            if (info.contains("texCoord") && info["texCoord"].is_number_integer()) set = info["texCoord"].get<int>();
            if (info.contains("extensions") && info["extensions"].contains("KHR_texture_transform")) {
                const json& tt = info["extensions"]["KHR_texture_transform"];
                if (tt.is_object() && tt.contains("texCoord") && tt["texCoord"].is_number_integer())
                    set = tt["texCoord"].get<int>();
            }
            highest = std::max(highest, set);
        });
    return highest;
}

}  // namespace mucosa::mesh
