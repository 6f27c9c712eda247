// mucosa dataset: synthetic endoscopy datasets. `export` writes a frames
// file's poses and intrinsics in other tools' formats (docs/datasets.md,
// "Exporting to other tools").
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/dataset/export.hpp>
#include <mucosa/fit/frames.hpp>

#include "commands.hpp"

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
    const fit::FrameSet set = fit::readFrames(a.frames, true);
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

// `dataset` is a group: one add...Command per subcommand.
void addDatasetCommand(CLI::App& app, Global& g) {
    CLI::App* dataset = app.add_subcommand(
        "dataset", "Synthetic endoscopy datasets; `export` writes poses and intrinsics for other tools");
    dataset->require_subcommand(1);
    addExportCommand(*dataset, g);
}

}  // namespace

MUCOSA_REGISTER_COMMAND(85, addDatasetCommand);

}  // namespace mucosa::cli
