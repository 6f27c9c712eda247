#include "render_manifest.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/version.hpp>
#include <mucosa/reflectance/tissue_texture.hpp>
#include <mucosa/shading/params.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// FNV-1a, 64 bits (Fowler, Noll and Vo 1991): detects an edited scene file;
// not a defence against anyone.
std::string fnv1a64(const std::vector<std::byte>& bytes) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (std::byte b : bytes) {
        h ^= static_cast<std::uint64_t>(b);
        h *= 0x100000001b3ull;
    }
    return fmt::format("{:016x}", h);
}

// A float as the double with its shortest decimal form (0.2f as 0.2, not
// 0.20000000298023224): the same float always gives the same number.
double shortest(float f) {
    return std::stod(fmt::format("{}", f));
}

std::string valueText(const json& v) {
    if (v.is_null()) return "none";
    if (v.is_string()) return v.get<std::string>();
    return v.dump();
}

// The settings compared, in the order they are reported, with their names in
// messages.
struct Setting {
    const char* key;
    const char* label;
};
constexpr Setting kSettings[] = {
    {"frames", "frames"},
    {"size", "size"},
    {"mode", "mode"},
    {"renderer", "renderer"},
    {"scene_file", "scene file"},
    {"scene_fnv1a64", "scene file content"},
    {"noise_space", "noise space"},
    {"specular_aa", "specular anti-aliasing"},
    {"reflectance_map_file", "reflectance map file"},
    {"variation", "variation"},
    {"outputs", "outputs"},
    {"lens", "lens"},          // absent: the pinhole of camera.fov_deg
    {"rgb_bits", "rgb bits"},  // absent: 8
};

}  // namespace

fs::path manifestPath(const fs::path& output) {
    fs::path p = output;
    return p.replace_extension(".render.json");
}

json renderManifest(const scene::Scene& scene, const SceneOptions& options, int frames, bool reference,
                    const std::string& outputs) {
    json m;
    m["what"] = "the settings of a frame sequence of mucosa render; a resumed run must match them";
    m["mucosa"] = std::string(version());
    m["frames"] = frames;
    m["size"] = fmt::format("{}x{}", scene.width, scene.height);
    m["mode"] = std::string(shading::modeName(scene.mode));
    m["renderer"] = reference ? "reference" : "opengl";
    if (scene.file.empty()) {
        m["scene_file"] = nullptr;  // the built-in default scene
        m["scene_fnv1a64"] = nullptr;
    } else {
        m["scene_file"] = fs::absolute(scene.file).lexically_normal().string();
        m["scene_fnv1a64"] = fnv1a64(readFile(scene.file));
    }
    m["noise_space"] = scene.noiseSpace == shading::NoiseSpace::Uv ? "uv" : "object";
    m["specular_aa"] = scene.specularAA;
    m["set"] = options.sets;
    if (scene.variation != 0) m["variation"] = scene.variation;  // absent = 0, as before the key existed
    if (!scene.tissue.empty()) {                                 // absent: the variation's texture alone
        json t = json::object();
        for (const auto& [key, value] : scene.tissue) t[key] = value;
        m["tissue"] = t;
    }
    if (!outputs.empty() && outputs != "rgb") m["outputs"] = outputs;  // absent = the colour frames alone
    json params = json::object();
    for (const shading::ParamInfo& p : shading::registry()) {
        const std::string key = fmt::format("{}.{}", p.group, p.name);
        if (p.components == 3) {
            const std::array<float, 3>& c = scene.params.color(p.id);
            params[key] = {shortest(c[0]), shortest(c[1]), shortest(c[2])};
        } else {
            params[key] = shortest(scene.params[p.id]);
        }
    }
    m["parameters"] = params;
    json map = reflectance::toJson(scene.mapParams);
    map.erase("preset");  // a label: the values are what count
    m["reflectance_map"] = map;
    m["reflectance_map_file"] =
        scene.reflectanceMap ? json(fs::absolute(*scene.reflectanceMap).lexically_normal().string()) : json(nullptr);
    return m;
}

std::string manifestDifferences(const json& recorded, const json& current) {
    std::vector<std::string> diffs;
    auto differ = [&](const std::string& label, const json& was, const json& now) {
        if (was != now) diffs.push_back(fmt::format("{} {} (this run: {})", label, valueText(was), valueText(now)));
    };
    auto field = [](const json& j, const std::string& key) {
        return j.is_object() && j.contains(key) ? j[key] : json();
    };
    for (const Setting& s : kSettings) differ(s.label, field(recorded, s.key), field(current, s.key));
    for (const char* group : {"parameters", "reflectance_map", "tissue"}) {
        const json was = field(recorded, group), now = field(current, group);
        const std::string prefix = std::string(group) == "parameters" ? "" : std::string(group) + ".";
        for (const auto& [key, value] : now.items()) differ(prefix + key, field(was, key), value);
        if (was.is_object())
            for (const auto& [key, value] : was.items())
                if (!now.contains(key)) differ(prefix + key, value, json());
    }
    constexpr std::size_t kShown = 4;
    std::string s;
    for (std::size_t i = 0; i < diffs.size() && i < kShown; ++i) s += (i ? ", " : "") + diffs[i];
    if (diffs.size() > kShown) s += fmt::format(" and {} more", diffs.size() - kShown);
    return s;
}

void requireResumable(const fs::path& output, const json& current, int existing) {
    const fs::path path = manifestPath(output);
    const std::string start = fmt::format("{} of this sequence already exist", count(existing, "frame"));
    const std::string fix = "--overwrite renders every frame again, or choose another -o";
    std::error_code ec;
    if (!fs::exists(path, ec))
        throw InputError(
            "resume", path.string(),
            fmt::format("{}, but this file, which records what they were made with, is missing; {}", start, fix));
    json recorded;
    try {
        recorded = json::parse(readTextFile(path));
    } catch (const json::exception& e) {
        throw InputError("resume", path.string(),
                         fmt::format("{}, but this record of them is not JSON ({}); {}", start, e.what(), fix));
    }
    const std::string diffs = manifestDifferences(recorded, current);
    if (!diffs.empty())
        throw InputError("resume", path.string(),
                         fmt::format("{} and were made with other settings: {}; {}", start, diffs, fix));
}

}  // namespace mucosa::cli
