#pragma once
// The record of what a frame sequence of `mucosa render --frames N` was made
// with, kept next to the frames (out.png -> out.render.json), so that resuming
// an interrupted run never mixes frames of two different runs.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include <mucosa/scene/scene.hpp>

#include "scene_options.hpp"

namespace mucosa::cli {

// out.png -> out.render.json
std::filesystem::path manifestPath(const std::filesystem::path& output);

// Everything that changes the pixels: frame count (the camera path is divided
// into that many poses), size, mode, renderer, the scene file (path and a hash
// of its content), the resolved noise space, specular anti-aliasing, every
// registry parameter and the reflectance map's parameters; plus, for people,
// the --set overrides and the Mucosa version.
// `outputs`: the frames' outputs (dataset::outputNames; "" or "rgb": the colour frames alone).
nlohmann::json renderManifest(const scene::Scene& scene, const SceneOptions& options, int frames, bool reference,
                              const std::string& outputs = "");

// The settings in which `recorded` and `current` differ, as
// "size 1280x1024 (this run: 640x480), mode noise (this run: vertex-phong)";
// empty when the frames on disk were made with the settings of this run.
std::string manifestDifferences(const nlohmann::json& recorded, const nlohmann::json& current);

// Before a run that keeps `existing` frames already on disk: throws
// InputError("resume", <manifest>, ...) naming what differs, or that nothing
// records how they were made, and suggesting --overwrite.
void requireResumable(const std::filesystem::path& output, const nlohmann::json& current, int existing);

}  // namespace mucosa::cli
