#pragma once
// Options shared by render, compare and view: the scene file and overrides
// (--mode, --size, --noise-space, --specular-aa, --variation, --look,
// --set group.name=value from the parameter registry).
#include <memory>
#include <string>
#include <vector>

#include <mucosa/scene/scene.hpp>

#include "commands.hpp"

namespace mucosa::cli {

struct SceneOptions {
    std::string sceneFile;
    std::string mode;
    std::string size;
    std::string noiseSpace;
    std::string specularAA;
    std::vector<std::string> sets;
    std::string variation;  // --variation SEED (scene::applyVariation)
    std::string look;       // --look FILE (scene::applyLook)
};

// Adds [scene.json], --mode, --size, --noise-space, --specular-aa, --variation, --look, --set to `c`.
void addSceneOptions(CLI::App* c, SceneOptions& o, bool withSize = true);

// Loads the scene (or the default one), prints its warnings (deprecated keys)
// and applies the overrides; InputError names the option on bad values.
scene::Scene resolveScene(const SceneOptions& o);

// "640x480" -> (640, 480); InputError(option, ...) otherwise.
std::pair<int, int> parseSize(const std::string& text, const std::string& option = "--size");

}  // namespace mucosa::cli
