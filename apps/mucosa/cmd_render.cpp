// mucosa render: frames of a scene, headless (EGL), to PNG files.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include <unistd.h>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/core/parallel.hpp>
#include <mucosa/core/version.hpp>
#include <mucosa/dataset/ground_truth.hpp>
#include <mucosa/dataset/lens.hpp>
#include <mucosa/dataset/raycast.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/render/offscreen.hpp>

#include "render_manifest.hpp"
#include "scene_options.hpp"

namespace mucosa::cli {

namespace {

struct RenderArgs {
    SceneOptions scene;
    std::string output;
    int frames = 0;
    bool overwrite = false;
    bool reference = false;
    std::string outputs;  // --outputs (empty: the scene's "outputs", else the colour frames alone)
    double depthScaleMm = dataset::kDefaultDepthPngScaleMm;
    std::string lens;  // --lens FILE (overrides the scene's camera.lens)
    int rgbBits = 8;   // --rgb-bits
};

// The scene's lens model (camera.lens, or --lens), checked against the
// frame size; nullopt: the pinhole of camera.fov_deg.
std::optional<dataset::Lens> sceneLens(const scene::Scene& scene) {
    std::optional<dataset::Lens> lens;
    std::string where;
    if (!scene.lensModelFile.empty()) {
        where = scene.lensModelFile.string();
        if (!std::filesystem::exists(scene.lensModelFile)) throw IoError("lens", where, "no such file");
        lens = dataset::readLensFile(scene.lensModelFile);
    } else if (!scene.lensModelJson.empty()) {
        where = scene.file.empty() ? "the scene" : scene.file.string();
        lens = dataset::lensFromJson(nlohmann::json::parse(scene.lensModelJson), where, "camera.lens.");
    }
    if (lens && (lens->width != scene.width || lens->height != scene.height))
        throw InputError("lens", where,
                         fmt::format("is for {}x{} frames and the frames are {}x{} (render at the lens's size: "
                                     "--size {}x{})",
                                     lens->width, lens->height, scene.width, scene.height, lens->width, lens->height));
    return lens;
}

// The dataset manifest beside the frames: out.png -> out.frames.json.
std::filesystem::path datasetManifestPath(const std::filesystem::path& output) {
    std::filesystem::path p = output;
    return p.replace_extension(".frames.json");
}

// The frames file `mucosa fit` reads (intrinsics, camera_to_world in OpenCV
// axes and mm), with the outputs' files and conventions and the settings
// that made them.
void writeDatasetManifest(const std::filesystem::path& output, const scene::Scene& scene,
                          const std::vector<camera::Pose>& poses, const std::vector<std::filesystem::path>& names,
                          const dataset::Outputs& outputs, double depthScaleMm, const nlohmann::json& settings,
                          const mesh::Centerline& tree, const std::optional<dataset::Lens>& lens) {
    fit::FrameSet set;
    set.response.toneCurve = static_cast<int>(scene.params[shading::Param::ToneCurve]);
    set.response.vignetting = scene.params[shading::Param::Vignetting];
    // The renderer's tip light is in x right, y up, z forward; OpenCV's y is down.
    set.lightOffset = {scene.light.offset[0], -scene.light.offset[1], scene.light.offset[2]};
    fit::Intrinsics K = dataset::intrinsicsOf(scene.lens, scene.width, scene.height);
    if (lens && lens->model != dataset::LensModel::Omnidirectional) {
        K.fx = lens->fx, K.fy = lens->fy, K.cx = lens->cx, K.cy = lens->cy;
        if (lens->model == dataset::LensModel::Pinhole) K.k1 = lens->k1, K.k2 = lens->k2;
    }
    for (std::size_t i = 0; i < poses.size(); ++i) {
        fit::Frame f;
        f.image = names[i];
        f.K = K;
        f.cameraToWorld = dataset::cameraToWorldOf(poses[i]);
        set.frames.push_back(f);
    }
    nlohmann::json extra;
    extra["outputs"] = dataset::describeOutputs(output, static_cast<int>(poses.size()), outputs, depthScaleMm, &tree);
    extra["conventions"] = {
        {"camera_axes", "OpenCV: x right, y down, z forward"},
        {"camera_to_world", "row-major 4x4, rotation columns = the camera's axes in world coordinates, mm"},
        {"intrinsics", "pinhole, pixel centres at integer coordinates (the first pixel's centre is (0, 0))"},
        {"world_units", "mm"},
        {"image_rows", "the first row is the top of the picture"}};
    if (lens && lens->model != dataset::LensModel::Pinhole) {
        // The frames' intrinsics hold the lens's focal lengths and centre
        // (none for the omnidirectional model); the lens itself is here, and
        // `mucosa fit`, which reads pinhole frames, refuses the file.
        extra["lens"] = dataset::lensJson(*lens);
        extra["conventions"]["intrinsics"] = fmt::format(
            "the {} lens in 'lens' (docs/datasets.md, \"Lens models\"); pixel centres at integer "
            "coordinates",
            dataset::lensModelName(lens->model));
    }
    extra["dataset"] = {{"made_by", "mucosa render"}, {"mucosa", std::string(version())}, {"settings", settings}};
    fit::writeFrames(datasetManifestPath(output), set, extra);
}

void run(const RenderArgs& a, const Global& g) {
    namespace fs = std::filesystem;
    scene::Scene scene = resolveScene(a.scene);
    const int frames = a.frames > 0 ? a.frames : scene.frames;
    const fs::path out = a.output;
    if (out.extension() != ".png") throw InputError("--output", out.string(), "must end in .png");
    requireWritable(out);
    // What each frame writes: --outputs, else the scene's "outputs"; with
    // either, a dataset manifest (out.frames.json) goes beside the frames.
    const bool asDataset = !a.outputs.empty() || !scene.outputs.empty();
    dataset::Outputs outputs =
        !a.outputs.empty() ? dataset::parseOutputs(a.outputs, "--outputs", "the command line")
        : asDataset
            ? dataset::parseOutputs(scene.outputs, "outputs", scene.file.empty() ? "the scene" : scene.file.string())
            : dataset::Outputs{};
    outputs.rgbBits = a.rgbBits;
    if (a.rgbBits == 16 && a.reference)
        throw InputError("--rgb-bits", "the command line", "16-bit frames come from OpenGL; drop --reference");
    if (!(a.depthScaleMm > 0 && a.depthScaleMm <= 1000))
        throw InputError("--depth-png-scale", "the command line", "must be in (0, 1000] mm");
    std::vector<fs::path> names;
    for (int i = 0; i < frames; ++i) names.push_back(frames == 1 ? out : render::frameName(out, i));
    // A frame is on disk when every one of its outputs is (each is written
    // atomically, so a file that exists is complete).
    auto onDisk = [&](int i) {
        for (const fs::path& p : dataset::outputFiles(names[static_cast<std::size_t>(i)], outputs))
            if (!fs::exists(p)) return false;
        return true;
    };
    // A sequence is resumable: frames already on disk are kept, if the record
    // next to them says they were made with this run's settings.
    if (!a.lens.empty()) {
        scene.lensModelFile = a.lens;
        scene.lensModelJson.clear();
    }
    const std::optional<dataset::Lens> lens = sceneLens(scene);
    if (lens && a.reference)
        throw InputError("--reference", "the command line",
                         "renders through the pinhole only; render through the lens without it");
    nlohmann::json manifest = renderManifest(scene, a.scene, frames, a.reference, dataset::outputNames(outputs));
    if (lens) manifest["lens"] = dataset::lensJson(*lens);
    if (a.rgbBits != 8) manifest["rgb_bits"] = a.rgbBits;  // absent: 8
    int existing = 0;
    if (frames > 1 && !a.overwrite)
        for (int i = 0; i < frames; ++i) existing += onDisk(i);
    if (existing > 0) requireResumable(out, manifest, existing);
    if (frames > 1 && existing == frames) {
        info(g, fmt::format("all {} exist ({} ...) and match this run; nothing to do (--overwrite renders them again)",
                            count(frames, "frame"), names.front().string()));
        return;
    }
    // One mode per run: a mode that reads no map (procedural, the baselines)
    // does not generate one.
    const scene::SceneAssets assets = scene::loadAssets(scene, g.threads, shading::info(scene.mode).readsMap);
    for (const std::string& n : assets.notes) info(g, n);
    const std::vector<camera::Pose> poses = scene::cameraPoses(scene, assets, frames);
    std::unique_ptr<render::OffscreenSession> session;
    if (!a.reference) {
        session = std::make_unique<render::OffscreenSession>(scene, assets, scene.width, scene.height);
        info(g, "GL_RENDERER: " + session->glRendererName());
        if (lens) {
            session->renderer().setLensRays(dataset::rayImage(*lens));
            info(g, fmt::format("lens: {} {}x{}, drawn through a cube map of {}-pixel faces",
                                dataset::lensModelName(lens->model), lens->width, lens->height,
                                session->renderer().cubeFaceSize()));
        }
    }
    const shading::Textures refTextures = scene::referenceTextures(scene, assets);
    const bool tty = isatty(2) && !g.quiet;
    const auto t0 = std::chrono::steady_clock::now();
    int written = 0, skipped = 0;
    // Auto-exposure carries state from frame to frame. A resumed run renders
    // (and discards) the frames just before the first missing one again, so
    // the exposure has settled as in an uninterrupted run: after
    // kSettleTimeConstants time constants the state left differs by e^-8.
    int firstMissing = 0;
    while (firstMissing < frames && frames > 1 && !a.overwrite && onDisk(firstMissing)) ++firstMissing;
    constexpr float kSettleTimeConstants = 8.0f;
    const int settleFrames = static_cast<int>(std::ceil(
        kSettleTimeConstants * scene.params[shading::Param::Adaptation] * scene.params[shading::Param::FrameRate]));
    shading::ExposureState exposure;
    // The ground truth of frame i: the manifest's camera on the scene's mesh.
    const fit::Intrinsics K = dataset::intrinsicsOf(scene.lens, scene.width, scene.height);
    auto cameraToWorld = [&](int i) { return dataset::cameraToWorldOf(poses[static_cast<std::size_t>(i)]); };
    // Through a lens: exact per pixel-centre ray (the rays the frame is drawn
    // along), cast into a tree of the mesh built once.
    std::optional<dataset::RayCaster> caster;
    if (lens && outputs.any()) caster.emplace(assets.mesh);
    auto truthOf = [&](int i) {
        dataset::GroundTruth t =
            caster ? dataset::groundTruth(*caster, *lens, cameraToWorld(i), scene.lens.nearMm, g.threads)
                   : dataset::groundTruth(assets.mesh, K, cameraToWorld(i), scene.lens.nearMm, g.threads);
        const std::vector<std::uint8_t> mask = dataset::fieldOfView(
            scene::frameSetup(scene, poses[static_cast<std::size_t>(i)], scene.width, scene.height));
        for (std::size_t p = 0; p < mask.size(); ++p) t.inView[p] = t.inView[p] && mask[p];
        return t;
    };
    std::shared_ptr<const dataset::GroundTruth> previous;
    int previousIndex = -1;
    // Each frame's files are encoded and written on a background thread while
    // the next frame renders (at most two frames queued: memory stays flat).
    SerialWorker writer(2);
    // Branch labels: each vertex's branch, once.
    std::vector<std::int32_t> vertexBranch;
    if (outputs.branch) {
        if (assets.centerlineTree.branches.empty())
            throw InputError("--outputs", "branch",
                             "needs the airway's centerline tree (the phantom, a centerline JSON beside the mesh or in "
                             "camera.path.centerline, or one computed from the mesh), which this scene's camera path "
                             "does not have");
        vertexBranch = dataset::vertexBranches(assets.mesh, assets.centerlineTree);
    }
    auto renderFrame = [&](int i) {
        shading::FrameSetup f = scene::frameSetup(scene, poses[static_cast<std::size_t>(i)], scene.width, scene.height);
        f.frameIndex = i;
        return a.reference ? shading::renderReference(assets.mesh, f, refTextures, &exposure) : session->renderFrame(f);
    };
    for (int i = 0; i < frames; ++i) {
        const fs::path& name = names[static_cast<std::size_t>(i)];
        if (frames > 1 && !a.overwrite && onDisk(i)) {
            ++skipped;
            // From shortly before the first missing frame on, every frame
            // carries the exposure to the next missing one.
            const bool settle = scene.params[shading::Param::AutoExposure] != 0.0f && i >= firstMissing - settleFrames;
            if (settle) (void)renderFrame(i);
            continue;
        }
        auto rgb = std::make_shared<image::Image8>();
        auto rgb16 = std::make_shared<image::Image16>();
        if (outputs.rgb && a.rgbBits == 16) {
            shading::FrameSetup f =
                scene::frameSetup(scene, poses[static_cast<std::size_t>(i)], scene.width, scene.height);
            f.frameIndex = i;
            *rgb16 = session->renderFrame16(f);
        } else if (outputs.rgb) {
            *rgb = renderFrame(i);
        }
        auto encode = [rgb, rgb16] { return rgb16->empty() ? image::encodePng(*rgb) : image::encodePng(*rgb16); };
        std::shared_ptr<dataset::GroundTruth> truth;
        std::uint64_t truthBytes = 0;
        if (outputs.any()) {
            truth = std::make_shared<dataset::GroundTruth>(truthOf(i));
            if (outputs.branch) dataset::labelBranches(*truth, assets.mesh, vertexBranch);
            if (outputs.flow) {
                // The flow needs the frame before (kept from the last frame
                // rendered, else computed: the first frame of a resumed run).
                if (i > 0 && previousIndex != i - 1)
                    previous = std::make_shared<const dataset::GroundTruth>(truthOf(i - 1)), previousIndex = i - 1;
                const fit::Mat4 before = i > 0 ? cameraToWorld(i - 1) : cameraToWorld(i);
                if (lens)
                    dataset::flowToPrevious(*truth, *lens, cameraToWorld(i), i > 0 ? previous.get() : nullptr, before,
                                            scene.lens.nearMm);
                else
                    dataset::flowToPrevious(*truth, K, cameraToWorld(i), i > 0 ? previous.get() : nullptr, before,
                                            scene.lens.nearMm);
            }
            // Upper bound of the ground truth's files: float EXR / 16-bit PNG, uncompressed.
            const std::uint64_t px = static_cast<std::uint64_t>(scene.width) * scene.height;
            truthBytes = px * (outputs.depth * 6 + outputs.normals * 18 + outputs.mask + outputs.uv * 12 +
                               outputs.face * 4 + outputs.flow * 13 + outputs.branch * 2);
        }
        auto png = std::make_shared<std::vector<std::byte>>();
        if (written == 0) {
            // The first frame is encoded here: its size is the estimate for
            // the rest, and nothing is written before the disk check.
            if (outputs.rgb) *png = encode();
            if (frames - existing > 1) {
                // Refuse a run whose frames will not fit before writing any
                // of them (x1.25 for frames that compress less well, plus 64
                // MiB to spare).
                const std::uint64_t toWrite = static_cast<std::uint64_t>(frames - existing);
                // Absolute: the disk probe walks up from the path, and "fly.png" alone has no parent to walk to.
                const std::uint64_t perFrame = png->size() + png->size() / 4 + truthBytes;
                requireDisk(saturatingMul(toWrite, perFrame) + (64ull << 20), fs::absolute(out),
                            fmt::format("{} of ~{}", count(toWrite, "frame"), formatBytes(perFrame)));
            }
            if (frames > 1) writeFileAtomic(manifestPath(out), manifest.dump(2) + "\n");
            if (asDataset)
                writeDatasetManifest(out, scene, poses, names, outputs, a.depthScaleMm, manifest, assets.centerlineTree,
                                     lens);
        }
        // The colour frame last: a frame is complete when all its files are.
        writer.push([encode, png, truth, name, &outputs, scale = a.depthScaleMm] {
            if (truth) dataset::writeGroundTruth(*truth, name, outputs, scale);
            if (outputs.rgb) writeFileAtomic(name, png->empty() ? encode() : *png);
        });
        if (truth && outputs.flow) previous = truth, previousIndex = i;
        ++written;
        if (frames > 1 && !g.quiet) {
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const double rate = written / std::max(s, 1e-9);
            const int left = frames - existing - written;
            const std::string line =
                fmt::format("frame {}/{} ({:.0f}%) {} ({:.1f} frames/s, ETA {})", i + 1, frames,
                            100.0 * (i + 1) / frames, name.filename().string(), rate, formatDuration(left / rate));
            if (tty)
                std::fprintf(stderr, "\r%s\x1b[K", line.c_str());
            else if ((i + 1) % std::max(1, frames / 10) == 0 || i + 1 == frames)
                std::fprintf(stderr, "%s\n", line.c_str());
        }
    }
    writer.finish();
    if (tty && frames > 1) std::fprintf(stderr, "\n");
    if (frames == 1)
        info(g, fmt::format("wrote {} ({}x{}, mode {})", out.string(), scene.width, scene.height,
                            shading::modeName(scene.mode)));
    else
        info(g, fmt::format("wrote {} of {} .. {} ({}x{}, mode {}){}", count(written, "frame"), names.front().string(),
                            names.back().string(), scene.width, scene.height, shading::modeName(scene.mode),
                            skipped ? fmt::format(", kept {} existing", skipped) : ""));
}

void addRenderCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<RenderArgs>();
    CLI::App* c = app.add_subcommand("render", "Render a scene headless (EGL) to PNG: one frame or a camera path");
    c->footer(
        "Examples:\n  mucosa render -o frame.png\n  mucosa render scene.json -o fly.png --frames 120 "
        "--mode vertex-phong --size 1280x1024");
    addSceneOptions(c, a->scene);
    c->add_option("-o,--output", a->output,
                  "Output PNG; with --frames N: out_0000.png ... out_<N-1>.png and out.render.json, the settings they "
                  "were made with")
        ->required();
    c->add_option("--frames", a->frames, "Frames along the camera path [the scene's frames, 1]")
        ->check(wholeNumber(1, 1000000));
    c->add_flag("--overwrite", a->overwrite,
                "Start over: render every frame again, even those on disk (default: keep them and resume, if "
                "OUT.render.json says they were made with the same settings)");
    c->add_flag("--reference", a->reference, "Use the C++ reference renderer (no OpenGL; slow)");
    c->add_option("--outputs", a->outputs,
                  "What each frame writes, comma-separated: rgb, depth, normals, mask, uv, face, flow, branch (ground "
                  "truth beside "
                  "each frame, and OUT.frames.json: poses, intrinsics, every file's encoding and unit; "
                  "docs/datasets.md) [the scene's \"outputs\", else rgb]");
    c->add_option("--depth-png-scale", a->depthScaleMm,
                  "Millimetres per unit of the 16-bit depth PNG [0.01: up to 655 mm]");
    c->add_option("--rgb-bits", a->rgbBits,
                  "Bits per channel of the colour frames' PNGs: 8, or 16 (drawn into a float target and rounded "
                  "once) [8]")
        ->check(CLI::IsMember({8, 16}));
    c->add_option("--lens", a->lens,
                  "Render through this lens: a lens JSON (pinhole, fisheye, omnidirectional) or OCamCalib's "
                  "calib_results.txt, at its size (docs/datasets.md, \"Lens models\") [the scene's camera.lens, else "
                  "the pinhole of camera.fov_deg]");
    c->callback([a, &g] { run(*a, g); });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(40, addRenderCommand);

}  // namespace mucosa::cli
