#pragma once
// The frame loop of `mucosa render`, shared with `mucosa dataset run`: a
// camera path's frames and their ground truth, encoded and written on a
// background thread, resumable.
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <mucosa/dataset/ground_truth.hpp>

#include "commands.hpp"
#include "scene_options.hpp"

namespace mucosa::cli {

struct RenderArgs {
    SceneOptions scene;
    std::string output;
    int frames = 0;
    bool overwrite = false;
    bool reference = false;
    std::string outputs;  // --outputs (empty: the scene's "outputs", else the colour frames alone)
    double depthScaleMm = dataset::kDefaultDepthPngScaleMm;
    std::string lens;                    // --lens FILE (overrides the scene's camera.lens)
    int rgbBits = 8;                     // --rgb-bits
    std::string exrCompression = "zip";  // --exr-compression
    bool dataset = false;                // a plan's run: a dataset (frame records) whatever the outputs
};

// A dataset plan's share of a sequence (mucosa dataset run): which frames to
// render, when one is done, and what to do once its files are written.
struct PlanShard {
    // The frames to render, as [begin, end) segments. Auto-exposure restarts at
    // each segment's `warm` frame (frames warm..begin-1 are rendered and
    // discarded), so every frame's exposure is a function of the plan alone.
    struct Segment {
        int warm = 0, begin = 0, end = 0;
    };
    std::vector<Segment> segments;
    // Whether frame i is complete on disk (its checksum file exists).
    std::function<bool(int)> done;
    // Runs on the writer thread after frame i's files are written.
    std::function<void(int)> written;
};

// Frame `index` of `frames` written to `output`: out.png alone, else
// out_0000.png, out_0001.png, ...
std::filesystem::path sequenceFrameName(const std::filesystem::path& output, int frames, int index);

// The settings record of a run (OUT.render.json; a plan's "settings"): throws
// InputError on an unusable combination, before any work.
nlohmann::json sequenceSettings(const RenderArgs& a);

// Writes the dataset manifest of `a`'s frames (poses, intrinsics, every
// output's file pattern, relative to `file`'s folder), as `mucosa render`
// writes OUT.frames.json beside them.
void writeSequenceManifest(const RenderArgs& a, const Global& g, const std::filesystem::path& file);

// Renders `a` (mucosa render). With `shard`, only its segments' frames, no
// OUT.render.json and no dataset manifest: `mucosa dataset` keeps those.
void renderSequence(const RenderArgs& a, const Global& g, const PlanShard* shard = nullptr);

}  // namespace mucosa::cli
