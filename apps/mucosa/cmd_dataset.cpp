// mucosa dataset: synthetic endoscopy datasets. `plan`, `run`, `verify` and
// `slurm` make a dataset whose every frame is a pure function of (plan, frame
// index), renderable in shards on many machines (dataset_plan.hpp,
// docs/datasets.md, "Datasets on a cluster"); `export` writes a frames file's
// poses and intrinsics in other tools' formats ("Exporting to other tools").
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/checksum.hpp>
#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/version.hpp>
#include <mucosa/dataset/export.hpp>
#include <mucosa/frames/frames.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/shading/params.hpp>

#include "commands.hpp"
#include "dataset_plan.hpp"
#include "render_manifest.hpp"
#include "render_sequence.hpp"

namespace mucosa::cli {

namespace {

struct ExportArgs {
    std::string frames, format, out;
    double fps = 30.0;
    std::optional<double> scale;
};

std::string writtenFiles(const dataset::Export& e) {
    if (e.format != dataset::ExportFormat::Colmap) return e.files.front().path.string();
    return e.folder.string() + " (cameras.txt, images.txt, points3D.txt)";
}

void runExport(const ExportArgs& a, const Global& g) {
    const dataset::ExportFormat format = dataset::parseExportFormat(a.format, "--format");
    const frames::FrameSet set = frames::readFrames(a.frames, true);
    dataset::ExportOptions o;
    // A dataset rendered through a lens (mucosa render --lens) carries it.
    const nlohmann::json j = nlohmann::json::parse(readTextFile(a.frames), nullptr, false);
    if (j.is_object() && j.contains("lens")) o.lens = dataset::lensFromJson(j["lens"], a.frames, "lens.");
    o.fps = a.fps;
    o.scale = a.scale;
    o.source = a.frames;
    o.imageRoot = std::filesystem::path(a.frames).parent_path();
    // Everything is checked and built before the first file is touched.
    dataset::Export e;
    try {
        e = dataset::buildExport(set, format, a.out, o);
    } catch (const InputError& err) {
        if (err.subject() == "fps" || err.subject() == "scale")
            throw InputError("--" + err.subject(), "", err.reason());
        throw;
    }
    if (format == dataset::ExportFormat::Colmap) requireOutputDir(a.out);
    dataset::writeExport(e);
    if (e.skipped > 0)
        warn(fmt::format("left out {} of {} that mucosa register flagged as not converged", count(e.skipped, "frame"),
                         a.frames));
    std::string what = count(e.frames, "frame");
    if (format != dataset::ExportFormat::Tum) what += ", " + count(e.cameras, "camera");
    info(g, fmt::format("wrote {}: {}, units {}", writtenFiles(e), what, dataset::unitName(e.scale)));
}

void addExportCommand(CLI::App& dataset, Global& g) {
    auto x = std::make_shared<ExportArgs>();
    CLI::App* exp = dataset.add_subcommand(
        "export",
        "Write a frames file's poses and intrinsics as a TUM trajectory, a COLMAP model or nerfstudio's "
        "transforms.json");
    exp->footer(
        "Examples: mucosa dataset export frames.json --format tum -o trajectory.txt --fps 30\n"
        "          mucosa dataset export frames.json --format colmap -o sparse/0\n"
        "          mucosa dataset export frames.json --format nerfstudio -o transforms.json --scale 0.001\n"
        "Conventions and units: docs/datasets.md, \"Exporting to other tools\".");
    exp->add_option("frames", x->frames, "Frames file (frames.json: images, intrinsics, camera_to_world in mm)")
        ->required();
    exp->add_option("--format", x->format, "tum, colmap or nerfstudio")->required();
    exp->add_option("-o,--output", x->out,
                    "tum: the trajectory file; colmap: the model folder (created if its parent exists); "
                    "nerfstudio: the transforms.json file, or a folder to put it in")
        ->required();
    exp->add_option("--fps", x->fps, "TUM timestamps: frame i at i / fps seconds [30]");
    exp->add_option("--scale", x->scale,
                    "Output units per mm: 0.001 for metres [tum: 0.001 (metres); colmap, nerfstudio: 1 (mm)]");
    exp->callback([x, &g] { runExport(*x, g); });
}

// ---- plan, run, verify -------------------------------------------------------

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kPlanFormat = 1;

fs::path planFile(const fs::path& dir) {
    return dir / "plan.json";
}
// The frames' base name: DIR/frames/frame.png -> frame_0000.png, ...
fs::path framesOutput(const fs::path& dir) {
    return dir / "frames" / "frame.png";
}
fs::path checksumFile(const fs::path& rgbName) {
    fs::path p = rgbName;
    return p.replace_extension(".sha256");
}

// What a plan renders, as render options; paths absolute, so any machine
// that mounts the same filesystem renders the same frames.
json planArgs(const RenderArgs& a) {
    auto absolute = [](const std::string& p) {
        return p.empty() ? json(nullptr) : json(fs::absolute(p).lexically_normal().string());
    };
    return {{"scene", absolute(a.scene.sceneFile)},
            {"mode", a.scene.mode},
            {"size", a.scene.size},
            {"noise_space", a.scene.noiseSpace},
            {"specular_aa", a.scene.specularAA},
            {"set", a.scene.sets},
            {"variation", a.scene.variation},
            {"look", absolute(a.scene.look)},
            {"outputs", a.outputs},
            {"lens", absolute(a.lens)},
            {"rgb_bits", a.rgbBits},
            {"depth_png_scale", a.depthScaleMm},
            {"exr_compression", a.exrCompression},
            {"frames", a.frames}};
}

// What identifies a plan: everything that decides its frames' bytes.
std::string planHash(const json& plan) {
    json content;
    for (const char* key : {"format", "mucosa", "frames", "segment_frames", "warm_frames", "args", "settings"})
        content[key] = plan.at(key);
    return sha256Hex(content.dump());
}

// The plan's segments: auto-exposure restarts at each one's warm-up frame.
struct Plan {
    fs::path dir;
    RenderArgs args;
    json settings;
    int frames = 0, segmentFrames = 1, warmFrames = 0;
    dataset::Outputs outputs;
    int segments() const { return (frames + segmentFrames - 1) / segmentFrames; }
    PlanShard::Segment segment(int j) const {
        const int begin = j * segmentFrames;
        return {std::max(0, begin - warmFrames), begin, std::min(frames, begin + segmentFrames)};
    }
    fs::path frameName(int i) const { return sequenceFrameName(args.output, frames, i); }
};

Plan readPlan(const fs::path& dir) {
    const fs::path file = planFile(dir);
    const std::string where = file.string();
    if (!fs::exists(file)) throw InputError("plan", where, "no such file (mucosa dataset plan ... -o DIR writes it)");
    json j;
    try {
        j = json::parse(readTextFile(file));
    } catch (const json::exception& e) {
        throw InputError("plan", where, fmt::format("is not JSON ({})", e.what()));
    }
    try {
        if (j.at("format").get<int>() != kPlanFormat)
            throw InputError(
                "plan", where,
                fmt::format("has format {}; this Mucosa reads format {}", j.at("format").get<int>(), kPlanFormat));
        if (j.at("mucosa").get<std::string>() != version())
            throw InputError("plan", where,
                             fmt::format("was made by Mucosa {} and this is {}: every shard of a plan must be "
                                         "rendered by the same version (same bytes)",
                                         j.at("mucosa").get<std::string>(), version()));
        Plan p;
        p.dir = dir;
        const json& a = j.at("args");
        auto text = [&](const char* key) { return a.at(key).is_null() ? std::string() : a.at(key).get<std::string>(); };
        p.args.scene.sceneFile = text("scene");
        p.args.scene.mode = text("mode");
        p.args.scene.size = text("size");
        p.args.scene.noiseSpace = text("noise_space");
        p.args.scene.specularAA = text("specular_aa");
        p.args.scene.sets = a.at("set").get<std::vector<std::string>>();
        p.args.scene.variation = text("variation");
        if (a.contains("look")) p.args.scene.look = text("look");  // absent in plans made before looks existed
        p.args.outputs = text("outputs");
        p.args.lens = text("lens");
        p.args.rgbBits = a.at("rgb_bits").get<int>();
        p.args.depthScaleMm = a.at("depth_png_scale").get<double>();
        p.args.exrCompression = a.value("exr_compression", std::string("zip"));  // absent in older plans: zip
        p.args.frames = a.at("frames").get<int>();
        p.args.output = framesOutput(dir).string();
        p.settings = j.at("settings");
        p.frames = j.at("frames").get<int>();
        p.segmentFrames = j.at("segment_frames").get<int>();
        p.warmFrames = j.at("warm_frames").get<int>();
        if (p.frames < 1 || p.segmentFrames < 1 || p.warmFrames < 0 || p.frames != p.args.frames)
            throw InputError("plan", where, "has inconsistent frame counts");
        if (j.at("content_sha256").get<std::string>() != planHash(j))
            throw InputError("plan", where, "was edited: its content does not match its content_sha256");
        p.outputs = dataset::parseOutputs(p.settings.value("outputs", std::string("rgb")), "outputs", where);
        p.outputs.rgbBits = p.args.rgbBits;
        // A plan is a dataset whatever its outputs: its frames have records.
        p.args.dataset = true;
        p.outputs.record = true;
        return p;
    } catch (const json::exception& e) {
        throw InputError("plan", where, fmt::format("is not a Mucosa plan ({})", e.what()));
    }
}

// The scene and its files still give the settings the plan recorded.
void requireUnchanged(const Plan& p) {
    const std::string diffs = manifestDifferences(p.settings, sequenceSettings(p.args));
    if (!diffs.empty())
        throw InputError("plan", planFile(p.dir).string(),
                         fmt::format("no longer matches its scene: {}; plan again into a new folder", diffs));
}

struct PlanArgs {
    RenderArgs render;
    std::string dir;
    int segmentFrames = 0;  // 0: from auto-exposure's settling time
};

void runPlan(PlanArgs& a, const Global& g) {
    const fs::path dir = a.dir;
    requireOutputDir(dir);
    a.render.output = framesOutput(dir).string();
    const json settings = sequenceSettings(a.render);  // checks every option
    const scene::Scene scene = resolveScene(a.render.scene);
    // Auto-exposure settles within 8 time constants (the state left differs
    // by e^-8): a segment renders that many frames before its first, and
    // segments are 4x longer, so the warm-up costs at most a quarter more.
    const bool autoExposure = scene.params[shading::Param::AutoExposure] != 0.0f;
    const int warm = autoExposure ? static_cast<int>(std::ceil(8.0f * scene.params[shading::Param::Adaptation] *
                                                               scene.params[shading::Param::FrameRate]))
                                  : 0;
    const int segment = a.segmentFrames > 0 ? a.segmentFrames : autoExposure ? std::max(32, 4 * warm) : 1;
    json j;
    j["what"] = "a Mucosa dataset plan: every frame is a function of this file and its index (docs/datasets.md)";
    j["format"] = kPlanFormat;
    j["mucosa"] = std::string(version());
    j["frames"] = a.render.frames;
    j["segment_frames"] = segment;
    j["warm_frames"] = warm;
    j["args"] = planArgs(a.render);
    j["settings"] = settings;
    j["content_sha256"] = planHash(j);
    const fs::path file = planFile(dir);
    if (fs::exists(file)) {
        json old = json::parse(readTextFile(file), nullptr, false);
        if (!old.is_object() || old.value("content_sha256", std::string()) != j["content_sha256"])
            throw InputError("plan", file.string(),
                             "exists and plans something else; choose another folder (its frames stay as they are)");
        info(g, fmt::format("{} already plans this dataset; nothing to do", file.string()));
        return;
    }
    fs::create_directories(dir);
    writeFileAtomic(file, j.dump(2) + "\n");
    info(g, fmt::format("wrote {}: {} at {}x{}, outputs {}, {} of {} (auto-exposure warm-up {})", file.string(),
                        count(static_cast<std::uint64_t>(a.render.frames), "frame"), scene.width, scene.height,
                        settings.value("outputs", std::string("rgb")),
                        count(static_cast<std::uint64_t>((a.render.frames + segment - 1) / segment), "segment"),
                        count(static_cast<std::uint64_t>(segment), "frame"), count(warm, "frame")));
    info(g, fmt::format("next: mucosa dataset run {} [--shard I/K], or mucosa dataset slurm {} --shards K",
                        dir.string(), dir.string()));
}

// "I/K" -> (I, K), 0 <= I < K.
std::pair<int, int> parseShard(const std::string& text) {
    const auto slash = text.find('/');
    auto number = [&](const std::string& s) {
        if (s.empty() || s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos)
            throw InputError("--shard", text, "must be I/K with whole numbers, 0 <= I < K (e.g. 0/4)");
        return std::stoi(s);
    };
    if (slash == std::string::npos)
        throw InputError("--shard", text, "must be I/K with whole numbers, 0 <= I < K (e.g. 0/4)");
    const int i = number(text.substr(0, slash)), k = number(text.substr(slash + 1));
    if (k < 1 || i >= k) throw InputError("--shard", text, "must be I/K with 0 <= I < K (e.g. 0/4 .. 3/4)");
    return {i, k};
}

// The checksum file: `sha256sum -c` reads it in the frames' folder.
void writeChecksums(const Plan& p, int i) {
    const fs::path name = p.frameName(i);
    std::string text;
    for (const fs::path& f : dataset::outputFiles(name, p.outputs))
        text += sha256File(f) + "  " + f.filename().string() + "\n";
    writeFileAtomic(checksumFile(name), text);
}

struct RunArgs {
    std::string dir, shard;
};

void runShard(const RunArgs& a, const Global& g) {
    const Plan p = readPlan(a.dir);
    requireUnchanged(p);
    const auto [index, shards] = a.shard.empty() ? std::pair{0, 1} : parseShard(a.shard);
    // Shard I of K: a contiguous run of whole segments (the flow of a
    // segment's first frame needs only the poses before it).
    const int segments = p.segments();
    const int first = static_cast<int>(static_cast<long long>(index) * segments / shards);
    const int last = static_cast<int>(static_cast<long long>(index + 1) * segments / shards);
    PlanShard shard;
    for (int j = first; j < last; ++j) shard.segments.push_back(p.segment(j));
    if (shard.segments.empty()) {
        info(g, fmt::format("shard {}/{} has no frames ({} in {} for {} shards)", index, shards,
                            count(p.frames, "frame"), count(segments, "segment"), shards));
        return;
    }
    shard.done = [&p](int i) { return fs::exists(checksumFile(p.frameName(i))); };
    shard.written = [&p](int i) { writeChecksums(p, i); };
    fs::create_directories(framesOutput(p.dir).parent_path());
    // A task killed mid-write (SIGKILL, a node lost) leaves its temporaries:
    // those of the frames this shard renders again go (no other task writes
    // them).
    std::vector<fs::path> again;
    for (const PlanShard::Segment& s : shard.segments)
        for (int i = s.begin; i < s.end; ++i)
            if (!shard.done(i)) {
                for (const fs::path& f : dataset::outputFiles(p.frameName(i), p.outputs)) again.push_back(f);
                again.push_back(checksumFile(p.frameName(i)));
            }
    if (const std::size_t n = removeStaleTemporaries(again); n > 0)
        info(g, fmt::format("removed {} an interrupted run left", count(n, "unfinished temporary file")));
    info(g, fmt::format("shard {}/{}: frames {} .. {} of {}", index, shards, shard.segments.front().begin,
                        shard.segments.back().end - 1, p.frames));
    renderSequence(p.args, g, &shard);
}

// "2, 5-7, 9"
std::string ranges(const std::vector<int>& v) {
    std::string s;
    for (std::size_t i = 0; i < v.size();) {
        std::size_t j = i;
        while (j + 1 < v.size() && v[j + 1] == v[j] + 1) ++j;
        if (!s.empty()) s += ", ";
        s += j == i ? fmt::format("{}", v[i]) : fmt::format("{}-{}", v[i], v[j]);
        i = j + 1;
    }
    return s;
}

// Why a frame's files are not what was written, or "" when they are.
std::string frameProblem(const Plan& p, int i) {
    const fs::path name = p.frameName(i);
    std::istringstream in(readTextFile(checksumFile(name)));
    std::map<std::string, std::string> sums;
    for (std::string hash, file; in >> hash >> file;) sums[file] = hash;
    for (const fs::path& f : dataset::outputFiles(name, p.outputs)) {
        const std::string file = f.filename().string();
        if (!sums.count(file)) return file + " is not in its checksum file";
        if (!fs::exists(f)) return file + " is missing";
        if (sha256File(f) != sums[file]) return file + " does not match its checksum";
        try {
            if (f.extension() == ".exr")
                (void)image::readExr(f);
            else if (f.extension() == ".json")
                (void)dataset::readFrameExposure(f);
            else
                (void)image::readPng(f);
        } catch (const Error& e) {
            return file + " does not decode (" + e.what() + ")";
        }
    }
    return "";
}

void runVerify(const std::string& dirText, const Global& g) {
    const Plan p = readPlan(dirText);
    std::vector<int> missing, damaged;
    std::string firstProblem;
    std::string sums;
    const fs::path framesDir = framesOutput(p.dir).parent_path();
    for (int i = 0; i < p.frames; ++i) {
        if (!fs::exists(checksumFile(p.frameName(i)))) {
            missing.push_back(i);
            continue;
        }
        const std::string problem = frameProblem(p, i);
        if (!problem.empty()) {
            // A rerun renders it again: its checksum file (the mark that it is
            // done) goes; its files stay until they are replaced.
            if (firstProblem.empty()) firstProblem = fmt::format("frame {}: {}", i, problem);
            damaged.push_back(i);
            fs::remove(checksumFile(p.frameName(i)));
            continue;
        }
        sums += readTextFile(checksumFile(p.frameName(i)));
    }
    if (!missing.empty() || !damaged.empty()) {
        std::string what;
        if (!missing.empty())
            what = fmt::format("{} of {} missing ({})", count(missing.size(), "frame"), p.frames, ranges(missing));
        if (!damaged.empty())
            what +=
                fmt::format("{}{} of {} damaged ({}; {}), their checksum files removed", what.empty() ? "" : " and ",
                            count(damaged.size(), "frame"), p.frames, ranges(damaged), firstProblem);
        throw InputError("dataset", p.dir.string(),
                         fmt::format("{}; `mucosa dataset run {}` (or its shards) renders them", what, p.dir.string()));
    }
    // Complete: one checksum list for the whole dataset (`sha256sum -c
    // SHA256SUMS` in DIR) and the manifest.
    std::string all;
    std::istringstream in(sums);
    for (std::string line; std::getline(in, line);) {
        const auto gap = line.find("  ");
        if (gap != std::string::npos) all += line.substr(0, gap + 2) + "frames/" + line.substr(gap + 2) + "\n";
    }
    writeFileAtomic(p.dir / "SHA256SUMS", all);
    writeSequenceManifest(p.args, g, p.dir / "frames.json");
    info(g, fmt::format("verified {} in {}: every file present, decoded and matching its checksum; wrote {} and {}",
                        count(p.frames, "frame"), framesDir.string(), (p.dir / "frames.json").string(),
                        (p.dir / "SHA256SUMS").string()));
}

void addPlanCommands(CLI::App& dataset, Global& g) {
    auto pa = std::make_shared<PlanArgs>();
    CLI::App* plan = dataset.add_subcommand(
        "plan", "Plan a dataset: the scene, settings and frame count, in DIR/plan.json (render it with `run`)");
    plan->footer(
        "Example: mucosa dataset plan scene.json --frames 2000 --outputs rgb,depth,normals,flow -o data\n"
        "         mucosa dataset run data --shard 0/4   (one of four machines; or `mucosa dataset slurm`)\n"
        "         mucosa dataset verify data\n"
        "docs/datasets.md, \"Datasets on a cluster\".");
    addSceneOptions(plan, pa->render.scene);
    plan->add_option("-o,--output", pa->dir, "The dataset's folder (created if its parent exists)")->required();
    plan->add_option("--frames", pa->render.frames, "Frames along the camera path")
        ->required()
        ->check(wholeNumber(1, 10000000));
    plan->add_option("--outputs", pa->render.outputs,
                     "What each frame writes: rgb, linear, highlight, depth, normals, mask, uv, face, flow, branch (as "
                     "mucosa render) "
                     "[the scene's \"outputs\", else rgb]");
    plan->add_option("--depth-png-scale", pa->render.depthScaleMm,
                     "Millimetres per unit of the 16-bit depth PNG [0.01]");
    plan->add_option("--rgb-bits", pa->render.rgbBits, "Bits per channel of the colour frames: 8 or 16 [8]")
        ->check(CLI::IsMember({8, 16}));
    plan->add_option("--exr-compression", pa->render.exrCompression,
                     "Lossless compression of the float EXR outputs: zip, piz, zips, rle or none (as mucosa render) "
                     "[zip]");
    plan->add_option("--lens", pa->render.lens, "Render through this lens (as mucosa render --lens)");
    plan->add_option("--segment-frames", pa->segmentFrames,
                     "Frames per segment, the unit of sharding; auto-exposure restarts at each segment, warmed up "
                     "over the frames before it [auto-exposure on: 4x its settling time, at least 32; off: 1]")
        ->check(wholeNumber(1, 10000000));
    plan->callback([pa, &g] { runPlan(*pa, g); });

    auto ra = std::make_shared<RunArgs>();
    CLI::App* run = dataset.add_subcommand(
        "run",
        "Render a plan's frames, or shard I of K of them: atomic per frame, resumable, the same bytes "
        "whatever the sharding");
    run->add_option("dir", ra->dir, "The dataset's folder (mucosa dataset plan)")->required();
    run->add_option("--shard", ra->shard, "I/K: the I-th of K shards, 0 <= I < K [0/1: every frame]");
    run->callback([ra, &g] { runShard(*ra, g); });

    auto va = std::make_shared<std::string>();
    CLI::App* verify =
        dataset.add_subcommand("verify",
                               "Check every frame of a plan is there, decodes and matches its checksum; then write "
                               "DIR/frames.json and DIR/SHA256SUMS, else list what a rerun must render");
    verify->add_option("dir", *va, "The dataset's folder")->required();
    verify->callback([va, &g] { runVerify(*va, g); });
}

// `dataset` is a group: one add...Command per subcommand.
void addDatasetCommand(CLI::App& app, Global& g) {
    CLI::App* dataset = app.add_subcommand(
        "dataset",
        "Synthetic endoscopy datasets: plan, run (in shards), slurm, verify; export writes poses and intrinsics for "
        "other tools");
    dataset->require_subcommand(1);
    addPlanCommands(*dataset, g);
    addSlurmCommand(*dataset, g);
    addExportCommand(*dataset, g);
}

}  // namespace

MUCOSA_REGISTER_COMMAND(85, addDatasetCommand);

}  // namespace mucosa::cli
