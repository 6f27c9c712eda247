#include "scene_options.hpp"

#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/shading/params.hpp>

namespace mucosa::cli {

void addSceneOptions(CLI::App* c, SceneOptions& o, bool withSize) {
    c->add_option("scene", o.sceneFile,
                  "Scene file (.json, see docs/scene-format.md), or a mesh file (.obj, .ply, .stl, .gltf, .glb, ...: "
                  "the default scene with that mesh, flying along its centerline); default: the airway phantom");
    c->add_option("--mode", o.mode, "Shading mode: " + shading::modeList() + " [noise] (described by mucosa params)");
    if (withSize) c->add_option("--size", o.size, "Frame size WxH [640x480, or the scene's resolution]");
    c->add_option("--noise-space", o.noiseSpace,
                  "Procedural modes: evaluate the map's noise in texture space (uv) or as solid noise on the surface "
                  "(object: needs no UVs or tangents) [uv, or the scene's noise_space]");
    c->add_option("--specular-aa", o.specularAA,
                  "Specular anti-aliasing: on (Toksvig on the map's mips; octave fade procedurally) or off (the "
                  "full-resolution map, every octave) [on, or the scene's specular_aa]");
    c->add_option("--variation", o.variation,
                  "Patient variation: draw tissue colour, vessels, mucus, exposure and the scope's softness, noise and "
                  "glare for patient SEED (a whole number; 0 = the default look; ranges: docs/theory.md, \"Patient "
                  "variation\") [0, or the scene's variation]");
    c->add_option(
        "--look", o.look,
        "A look file (mucosa look fit writes one: the colour, vessels, mucus, highlights, exposure and camera "
        "fitted to a folder of real frames) applied over the scene and the variation; --set still overrides "
        "it");
    c->add_option("--set", o.sets,
                  "Override a parameter, e.g. --set material.shininess=80, --set reflectance_map.frequency=32 or "
                  "--set tissue.vessel_contrast=0.5 (repeatable; reflectance_map takes the keys of a scene's "
                  "\"reflectance_map\" object and applies to the generated map and the procedural mode; tissue those "
                  "of its \"tissue\" object, the generated texture's). Every parameter, its range and default: "
                  "mucosa params");
}

std::pair<int, int> parseSize(const std::string& text, const std::string& option) {
    const auto x = text.find('x');
    int w = 0, h = 0;
    auto num = [](std::string_view s, int& v) {
        const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
        return r.ec == std::errc() && r.ptr == s.data() + s.size();
    };
    if (x == std::string::npos || !num(std::string_view(text).substr(0, x), w) ||
        !num(std::string_view(text).substr(x + 1), h) || w < 16 || h < 16 || w > 8192 || h > 8192)
        throw InputError(option, "", "'" + text + "' is not WxH with 16..8192 pixels per side (e.g. 640x480)");
    return {w, h};
}

scene::Scene resolveScene(const SceneOptions& o) {
    scene::Scene s = o.sceneFile.empty() ? scene::defaultScene() : scene::loadScene(o.sceneFile);
    for (const std::string& w : s.warnings) warn(w);
    if (!o.mode.empty()) s.mode = shading::parseMode(o.mode, "--mode");
    if (!o.size.empty()) std::tie(s.width, s.height) = parseSize(o.size);
    if (!o.noiseSpace.empty()) {
        if (o.noiseSpace != "uv" && o.noiseSpace != "object")
            throw InputError("--noise-space", "", "'" + o.noiseSpace + "' is not uv or object");
        s.noiseSpace = o.noiseSpace == "uv" ? shading::NoiseSpace::Uv : shading::NoiseSpace::Object;
    }
    if (!o.specularAA.empty()) {
        if (o.specularAA != "on" && o.specularAA != "off")
            throw InputError("--specular-aa", "", "'" + o.specularAA + "' is not on or off");
        s.specularAA = o.specularAA == "on";
    }
    if (!o.variation.empty()) {
        std::uint64_t seed = 0;
        const char* end = o.variation.data() + o.variation.size();
        const auto r = std::from_chars(o.variation.data(), end, seed);
        if (r.ec != std::errc() || r.ptr != end)
            throw InputError("--variation", "",
                             "'" + o.variation + "' is not a whole number >= 0 (a patient seed; 0 = the default look)");
        scene::applyVariation(s, seed);
    }
    if (!o.look.empty()) scene::applyLook(s, o.look);
    for (const std::string& kv : o.sets) {
        const auto eq = kv.find('=');
        if (eq == std::string::npos) throw InputError("--set", "", "'" + kv + "' is not group.name=value");
        std::string key = kv.substr(0, eq);
        const std::string value = kv.substr(eq + 1);
        const auto dot = key.find('.');
        const std::string name = dot == std::string::npos ? key : key.substr(dot + 1);
        if (dot != std::string::npos && key.substr(0, dot) == "reflectance_map") {
            scene::setMapParameter(s, name, value);
            continue;
        }
        if (dot != std::string::npos && key.substr(0, dot) == "tissue") {
            double v = 0;
            const auto r = std::from_chars(value.data(), value.data() + value.size(), v);
            if (value.empty() || r.ec != std::errc() || r.ptr != value.data() + value.size())
                throw InputError("--set " + key, "", "'" + value + "' is not a number");
            scene::setTissueParameter(s, name, v, "--set " + key);
            continue;
        }
        const shading::ParamInfo* pi = shading::findParam(name);
        if (pi == nullptr || (dot != std::string::npos && key.substr(0, dot) != pi->group)) {
            std::vector<std::string> names;
            for (const shading::ParamInfo& p : shading::registry())
                names.push_back(dot == std::string::npos ? std::string(p.name) : fmt::format("{}.{}", p.group, p.name));
            const std::vector<std::string> close = nearest(key, names);
            throw InputError("--set", "",
                             fmt::format("unknown parameter '{}' ({}see mucosa params)", key,
                                         close.empty() ? "" : "did you mean '" + close.front() + "'? "));
        }
        std::vector<float> v;
        std::size_t pos = 0;
        while (pos <= value.size()) {
            const auto comma = value.find(',', pos);
            const std::string part = value.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
            float f = 0;
            const auto r = std::from_chars(part.data(), part.data() + part.size(), f);
            if (part.empty() || r.ec != std::errc() || r.ptr != part.data() + part.size())
                throw InputError("--set " + key, "", "'" + value + "' is not a number (colours: r,g,b)");
            v.push_back(f);
            if (comma == std::string::npos) break;
            pos = comma + 1;
        }
        const std::string field = "--set " + std::string(pi->group) + "." + std::string(pi->name);
        if (pi->components == 3) {
            if (v.size() != 3) throw InputError(field, "", "needs three numbers r,g,b");
            s.params.setColor(pi->id, {v[0], v[1], v[2]}, "", field);
        } else {
            if (v.size() != 1) throw InputError(field, "", "needs one number");
            s.params.set(pi->id, v[0], "", field);
        }
    }
    return s;
}

}  // namespace mucosa::cli
