// The frame loop of mucosa render and mucosa dataset run (render_sequence.hpp).
#include "render_sequence.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
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
#include <mucosa/dataset/orient.hpp>
#include <mucosa/dataset/raycast.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/render/offscreen.hpp>
#include <mucosa/render/renderer.hpp>

#include "render_manifest.hpp"

namespace mucosa::cli {

namespace {

// The bronchoscope preset {"model": "equidistant", "fov_deg": F} (F default
// camera.fov_deg): an equidistant fisheye at the frame's size whose image
// circle (camera.mask_radius x half the smaller side) spans F degrees.
std::optional<dataset::Lens> equidistantPreset(const nlohmann::json& j, const scene::Scene& scene,
                                               const std::string& where) {
    if (!j.is_object() || !j.contains("model") || j["model"] != "equidistant") return std::nullopt;
    for (auto it = j.begin(); it != j.end(); ++it)
        if (it.key() != "model" && it.key() != "fov_deg")
            throw InputError("field 'camera.lens." + it.key() + "'", where,
                             "is not a key of the equidistant preset (model, fov_deg)");
    double fov = scene.lens.fovDeg;
    if (j.contains("fov_deg")) {
        if (!j["fov_deg"].is_number() || !(j["fov_deg"].get<double>() > 0 && j["fov_deg"].get<double>() < 360))
            throw InputError("field 'camera.lens.fov_deg'", where, "must be a number of degrees in (0, 360)");
        fov = j["fov_deg"].get<double>();
    }
    const double circle = scene.params[shading::Param::MaskRadius] * 0.5 * std::min(scene.width, scene.height);
    dataset::Lens lens = dataset::equidistantFisheye(scene.width, scene.height, 120.0);
    lens.fx = lens.fy = circle / (0.5 * fov * M_PI / 180.0);
    dataset::validateLens(lens);
    return lens;
}

// The scene's lens model (camera.lens, or --lens), checked against the
// frame size; nullopt: the pinhole of camera.fov_deg.
std::optional<dataset::Lens> sceneLens(const scene::Scene& scene) {
    std::optional<dataset::Lens> lens;
    std::string where;
    if (!scene.lensModelJson.empty()) {
        const nlohmann::json j = nlohmann::json::parse(scene.lensModelJson);
        if (auto preset = equidistantPreset(j, scene, scene.file.empty() ? "the scene" : scene.file.string()))
            return preset;
    }
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
void writeDatasetManifest(const std::filesystem::path& manifestFile, const std::filesystem::path& output,
                          const scene::Scene& scene, const std::vector<camera::Pose>& poses,
                          const std::vector<std::filesystem::path>& names, const dataset::Outputs& outputs,
                          double depthScaleMm, const nlohmann::json& settings, const mesh::Centerline& tree,
                          const std::optional<dataset::Lens>& lens) {
    frames::FrameSet set;
    // Each frame's exposure, from its record where it is on disk (the
    // manifest is written again once every frame is).
    std::vector<double> exposures(names.size(), 0.0);
    if (dataset::hasRecord(outputs))
        for (std::size_t i = 0; i < names.size(); ++i) {
            const std::filesystem::path record = dataset::recordFile(names[i]);
            if (std::filesystem::exists(record)) exposures[i] = dataset::readFrameExposure(record);
        }
    // How to read the frames' pixels back to the signal. Only the
    // photographic modes' frames go through the scope's camera (camera.glsl,
    // Renderer::draw); the others write their values as they are: the brdf
    // modes texture x rho x delta, linear (their texture and rho, delta are
    // already a camera's linear output: mucosa fit's), the debug views
    // display values. For those the camera's settings describe nothing in the
    // frames: the manifest says linear, no vignetting. The photographic
    // frames: the tone curve, the vignetting, the colour enhancement and each
    // frame's exposure (frames[i].exposure, from its record), which `mucosa
    // fit` undoes. Not undone: the sensor's noise (random: the fit's robust
    // loss), the optics' softness (a blur under a pixel) and the mask (the
    // fit finds it in the frames).
    if (shading::info(scene.mode).photographic) {
        set.response.toneCurve = static_cast<int>(scene.params[shading::Param::ToneCurve]);
        set.response.vignetting = scene.params[shading::Param::Vignetting];
        set.response.colourGain = scene.params[shading::Param::Saturation];
        set.response.knee = scene.params[shading::Param::Knee];
        set.response.flare = scene.params[shading::Param::Flare];
        set.autoExposure = scene.params[shading::Param::AutoExposure] != 0.0f;
    } else {
        set.response.toneCurve = 0;  // linear
        set.response.vignetting = 0;
    }
    // The renderer's tip light is in x right, y up, z forward; OpenCV's y is down.
    set.lightOffset = {scene.light.offset[0], -scene.light.offset[1], scene.light.offset[2]};
    frames::Intrinsics K = dataset::intrinsicsOf(scene.lens, scene.width, scene.height);
    if (lens && lens->model != dataset::LensModel::Omnidirectional) {
        K.fx = lens->fx, K.fy = lens->fy, K.cx = lens->cx, K.cy = lens->cy;
        if (lens->model == dataset::LensModel::Pinhole) K.k1 = lens->k1, K.k2 = lens->k2;
    }
    for (std::size_t i = 0; i < poses.size(); ++i) {
        frames::Frame f;
        f.image = names[i];
        f.K = K;
        f.cameraToWorld = dataset::cameraToWorldOf(poses[i]);
        f.exposure = exposures[i];
        set.frames.push_back(f);
    }
    nlohmann::json extra;
    extra["outputs"] = dataset::describeOutputs(output, static_cast<int>(poses.size()), outputs, depthScaleMm, &tree);
    // The outputs' file patterns are relative to the manifest's folder.
    const std::filesystem::path folder =
        std::filesystem::absolute(output).parent_path().lexically_normal().lexically_relative(
            std::filesystem::absolute(manifestFile).parent_path().lexically_normal());
    if (!folder.empty() && folder != ".")
        for (auto& [key, o] : extra["outputs"].items())
            if (o.is_object() && o.contains("file") && o["file"].is_string())
                o["file"] = (folder / o["file"].get<std::string>()).generic_string();
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
    frames::writeFrames(manifestFile, set, extra);
}

// What a run renders: the scene with its overrides, the lens, the outputs
// and the settings record, checked before any work.
struct Prepared {
    scene::Scene scene;
    int frames = 1;
    dataset::Outputs outputs;
    bool asDataset = false;
    std::optional<dataset::Lens> lens;
    nlohmann::json manifest;
};

Prepared prepare(const RenderArgs& a) {
    Prepared p;
    p.scene = resolveScene(a.scene);
    scene::Scene& scene = p.scene;
    p.frames = a.frames > 0 ? a.frames : scene.frames;
    // What each frame writes: --outputs, else the scene's "outputs"; with
    // either, a dataset manifest (out.frames.json) goes beside the frames.
    p.asDataset = a.dataset || !a.outputs.empty() || !scene.outputs.empty();
    p.outputs = !a.outputs.empty()       ? dataset::parseOutputs(a.outputs, "--outputs", "the command line")
                : !scene.outputs.empty() ? dataset::parseOutputs(scene.outputs, "outputs",
                                                                 scene.file.empty() ? "the scene" : scene.file.string())
                                         : dataset::Outputs{};
    p.outputs.record = p.asDataset;
    p.outputs.rgbBits = a.rgbBits;
    p.outputs.exrCompression = image::parseExrCompression(a.exrCompression, "--exr-compression", "the command line");
    if (a.rgbBits == 16 && a.reference)
        throw InputError("--rgb-bits", "the command line", "16-bit frames come from OpenGL; drop --reference");
    if (!(a.depthScaleMm > 0 && a.depthScaleMm <= 1000))
        throw InputError("--depth-png-scale", "the command line", "must be in (0, 1000] mm");
    if (a.lens == "equidistant" || a.lens.starts_with("equidistant:")) {
        // The bronchoscope preset, at the frame's size.
        nlohmann::json j = {{"model", "equidistant"}};
        if (a.lens.size() > 12) {
            const std::string deg = a.lens.substr(12);
            char* end = nullptr;
            const double v = std::strtod(deg.c_str(), &end);
            if (deg.empty() || end != deg.c_str() + deg.size() || !std::isfinite(v))
                throw InputError("--lens", "the command line",
                                 "equidistant:DEG needs a number of degrees, not '" + deg + "'");
            j["fov_deg"] = v;
        }
        scene.lensModelJson = j.dump();
        scene.lensModelFile.clear();
    } else if (!a.lens.empty()) {
        scene.lensModelFile = a.lens;
        scene.lensModelJson.clear();
    }
    p.lens = sceneLens(scene);
    if ((p.outputs.linear || p.outputs.highlight) && a.reference)
        throw InputError("--outputs", "linear, highlight", "are drawn with OpenGL; drop --reference");
    if ((p.outputs.linear || p.outputs.highlight) && !shading::info(scene.mode).photographic)
        throw InputError("--outputs", "linear, highlight",
                         fmt::format("need a photographic mode; '{}' is a debug view", shading::modeName(scene.mode)));
    if (p.lens && a.reference)
        throw InputError("--reference", "the command line",
                         "renders through the pinhole only; render through the lens without it");
    p.manifest = renderManifest(scene, a.scene, p.frames, a.reference, dataset::outputNames(p.outputs));
    if (p.lens) p.manifest["lens"] = dataset::lensJson(*p.lens);
    if (a.rgbBits != 8) p.manifest["rgb_bits"] = a.rgbBits;  // absent: 8
    if (p.outputs.exrCompression != image::ExrCompression::Zip)
        p.manifest["exr_compression"] = a.exrCompression;  // absent: zip
    return p;
}

// One line on stderr when most of what the first frame's camera sees turns
// its unlit side to it (a mesh whose normals face out of the lumen, or the
// wrong lit_side): measured on the ray-cast ground truth of a 64-pixel-wide
// pinhole with the scene's field of view at that pose.
void warnIfBackFacesFace(const scene::Scene& scene, const scene::SceneAssets& assets, const camera::Pose& pose,
                         int threads) {
    constexpr int kWidth = 64;
    const int height = std::max(1, static_cast<int>(std::lround(double(kWidth) * scene.height / scene.width)));
    const frames::Intrinsics K = dataset::intrinsicsOf(scene.lens, kWidth, height);
    const dataset::GroundTruth truth =
        dataset::groundTruth(assets.mesh, K, dataset::cameraToWorldOf(pose), scene.lens.nearMm, threads);
    const dataset::BackFaceView v = dataset::backFacesSeen(
        truth, assets.mesh, {pose.position[0], pose.position[1], pose.position[2]}, scene.normalSign);
    if (v.seen == 0 || 2 * v.back <= v.seen) return;
    const bool culled = scene.closed.value_or(scene.mesh.kind == scene::MeshKind::Phantom);
    const char* side = scene.normalSign > 0 ? "front" : "back";
    warn(fmt::format(
        "the camera sees mostly back faces: {:.0f} % of the surface in the first frame turns its unlit side "
        "to it (lit_side \"{}\"; ray cast at {}x{}), so the walls {}; light the other side "
        "(\"lit_side\": \"{}\") or turn the mesh's normals into the lumen (mucosa mesh IN -o OUT "
        "--orient lumen)",
        100 * v.backFraction(), side, kWidth, height,
        culled ? "are culled (a closed scene)" : "render unlit (ambient light only)",
        scene.normalSign > 0 ? "back" : "front"));
}

}  // namespace

std::filesystem::path sequenceFrameName(const std::filesystem::path& output, int frames, int index) {
    return frames == 1 ? output : render::frameName(output, index);
}

nlohmann::json sequenceSettings(const RenderArgs& a) {
    return prepare(a).manifest;
}

void writeSequenceManifest(const RenderArgs& a, const Global& g, const std::filesystem::path& file) {
    Prepared prep = prepare(a);
    const scene::SceneAssets assets = scene::loadAssets(prep.scene, g.threads, false);
    const std::vector<camera::Pose> poses = scene::cameraPoses(prep.scene, assets, prep.frames);
    const std::filesystem::path out = a.output;
    std::vector<std::filesystem::path> names;
    for (int i = 0; i < prep.frames; ++i) names.push_back(sequenceFrameName(out, prep.frames, i));
    writeDatasetManifest(file, out, prep.scene, poses, names, prep.outputs, a.depthScaleMm, prep.manifest,
                         assets.centerlineTree, prep.lens);
}

void renderSequence(const RenderArgs& a, const Global& g, const PlanShard* shard) {
    namespace fs = std::filesystem;
    Prepared prep = prepare(a);
    scene::Scene& scene = prep.scene;
    const int frames = prep.frames;
    const dataset::Outputs& outputs = prep.outputs;
    const std::optional<dataset::Lens>& lens = prep.lens;
    const nlohmann::json& manifest = prep.manifest;
    const fs::path out = a.output;
    if (out.extension() != ".png") throw InputError("--output", out.string(), "must end in .png");
    requireWritable(out);
    std::vector<fs::path> names;
    for (int i = 0; i < frames; ++i) names.push_back(sequenceFrameName(out, frames, i));
    // A frame is on disk when every one of its outputs is (each is written
    // atomically, so a file that exists is complete); a plan's frame, when its
    // checksum file is.
    auto onDisk = [&](int i) {
        for (const fs::path& p : dataset::outputFiles(names[static_cast<std::size_t>(i)], outputs))
            if (!fs::exists(p)) return false;
        return true;
    };
    auto done = [&](int i) { return shard ? shard->done(i) : frames > 1 && !a.overwrite && onDisk(i); };
    // What to render: a plan's segments, else the whole path, from shortly
    // before the first missing frame (auto-exposure settles there as in an
    // uninterrupted run: after kSettleTimeConstants time constants the state
    // left differs by e^-8).
    constexpr float kSettleTimeConstants = 8.0f;
    const bool autoExposure = scene.params[shading::Param::AutoExposure] != 0.0f;
    std::vector<PlanShard::Segment> segments;
    int existing = 0, toRender = 0;
    if (shard) {
        segments = shard->segments;
        for (const PlanShard::Segment& s : segments)
            for (int i = s.begin; i < s.end; ++i) done(i) ? ++existing : ++toRender;
        if (toRender == 0) {
            info(g, fmt::format("all {} of this shard are done; nothing to do", count(existing, "frame")));
            return;
        }
    } else {
        for (int i = 0; i < frames; ++i) existing += done(i);
        toRender = frames - existing;
        // A sequence is resumable: frames already on disk are kept, if the
        // record next to them says they were made with this run's settings.
        if (existing > 0) requireResumable(out, manifest, existing);
        if (frames > 1 && existing == frames) {
            info(g,
                 fmt::format("all {} exist ({} ...) and match this run; nothing to do (--overwrite renders them again)",
                             count(frames, "frame"), names.front().string()));
            return;
        }
        // A run killed mid-write leaves its temporaries: those of the frames
        // rendered again go.
        std::vector<fs::path> again;
        for (int i = 0; i < frames; ++i)
            if (!done(i))
                for (const fs::path& f : dataset::outputFiles(names[static_cast<std::size_t>(i)], outputs))
                    again.push_back(f);
        if (const std::size_t n = removeStaleTemporaries(again); n > 0)
            info(g, fmt::format("removed {} an interrupted run left", count(n, "unfinished temporary file")));
        int firstMissing = 0;
        while (firstMissing < frames && done(firstMissing)) ++firstMissing;
        const int settleFrames = static_cast<int>(std::ceil(
            kSettleTimeConstants * scene.params[shading::Param::Adaptation] * scene.params[shading::Param::FrameRate]));
        segments.push_back({std::max(0, firstMissing - settleFrames), 0, frames});
    }
    // One mode per run: a mode that reads no map (procedural, the baselines)
    // does not generate one.
    const scene::SceneAssets assets = scene::loadAssets(scene, g.threads, shading::info(scene.mode).readsMap);
    for (const std::string& n : assets.notes) info(g, n);
    const std::vector<camera::Pose> poses = scene::cameraPoses(scene, assets, frames);
    const bool photographic = shading::info(scene.mode).photographic;
    bool oneFace = false;  // the lens drawn in one wide face (its near plane is planar)
    std::unique_ptr<render::OffscreenSession> session;
    if (!a.reference) {
        session = std::make_unique<render::OffscreenSession>(scene, assets, scene.width, scene.height);
        info(g, "GL_RENDERER: " + session->glRendererName());
        if (lens) {
            // The photographic modes' frames end at the scope's mask: the
            // rays beyond it are never seen.
            image::ImageF rays = dataset::rayImage(*lens);
            if (photographic) render::clipRaysToMask(rays, scene.params);
            oneFace = render::drawnInOneFace(rays);
            session->renderer().setLensRays(rays);
            info(g, fmt::format("lens: {} {}x{}, drawn through {} of {} pixels", dataset::lensModelName(lens->model),
                                lens->width, lens->height, oneFace ? "one wide face" : "a cube map with faces",
                                session->renderer().cubeFaceSize()));
        }
    }
    warnIfBackFacesFace(scene, assets, poses[static_cast<std::size_t>(segments.front().begin)], g.threads);
    const shading::Textures refTextures = scene::referenceTextures(scene, assets);
    const bool tty = isatty(2) && !g.quiet;
    const auto t0 = std::chrono::steady_clock::now();
    int written = 0, firstWritten = 0, lastWritten = frames - 1;
    shading::ExposureState exposure;
    // The ground truth of frame i: the manifest's camera on the scene's mesh.
    const frames::Intrinsics K = dataset::intrinsicsOf(scene.lens, scene.width, scene.height);
    auto cameraToWorld = [&](int i) { return dataset::cameraToWorldOf(poses[static_cast<std::size_t>(i)]); };
    // Through a lens: exact per pixel-centre ray (the rays the frame is drawn
    // along), cast into a tree of the mesh built once.
    std::optional<dataset::RayCaster> caster;
    if (lens && outputs.any()) caster.emplace(assets.mesh);
    auto truthOf = [&](int i) {
        dataset::GroundTruth t =
            caster ? dataset::groundTruth(*caster, *lens, cameraToWorld(i), scene.lens.nearMm, g.threads,
                                          oneFace ? dataset::NearClip::Planar : dataset::NearClip::CubeFaces)
                   : dataset::groundTruth(assets.mesh, K, cameraToWorld(i), scene.lens.nearMm, g.threads);
        // The scope's field-of-view mask is the camera's (camera.glsl): only
        // the photographic modes' frames go through it; the others (brdf,
        // the debug views) show the wall to the image's corners.
        if (!photographic) return t;
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
    // Each of a frame's files is a task of its own (writeGroundTruth), so
    // OpenEXR's own pool would only hand each block of scan lines to another
    // thread (measured: 5 000 context switches a frame at 640x480, none).
    if (outputs.any() || outputs.linear) image::setExrThreads(0);
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
    bool restart = false;  // the next frame rendered starts auto-exposure afresh
    auto setupOf = [&](int i) {
        shading::FrameSetup f = scene::frameSetup(scene, poses[static_cast<std::size_t>(i)], scene.width, scene.height);
        f.frameIndex = i;
        f.restartExposure = restart;
        restart = false;
        return f;
    };
    auto renderFrame = [&](int i) {
        const shading::FrameSetup f = setupOf(i);
        return a.reference ? shading::renderReference(assets.mesh, f, refTextures, &exposure) : session->renderFrame(f);
    };
    auto renderAndWrite = [&](int i) {
        const fs::path& name = names[static_cast<std::size_t>(i)];
        auto rgb = std::make_shared<image::Image8>();
        auto rgb16 = std::make_shared<image::Image16>();
        const bool draws = outputs.rgb || outputs.linear || outputs.highlight;
        if (draws && a.rgbBits == 16)
            *rgb16 = session->renderFrame16(setupOf(i));
        else if (draws)
            *rgb = renderFrame(i);
        // The colour frame's other developments, with the exposure it got:
        // its linear signal, and the highlights (its specular lobe's share).
        auto linear = std::make_shared<image::ImageF>();
        auto highlight = std::make_shared<image::Image8>();
        if (outputs.linear || outputs.highlight) {
            const float frameExposure = session->renderer().lastExposure();
            auto develop = [&](bool noise, bool specular) {
                shading::FrameSetup f =
                    scene::frameSetup(scene, poses[static_cast<std::size_t>(i)], scene.width, scene.height);
                f.frameIndex = i;
                f.fixedExposure = frameExposure;
                f.params.set(shading::Param::ToneCurve, 0.0f);
                f.params.set(shading::Param::Knee, 1.0f);  // the knee bends the response, not the signal
                if (!noise) f.params.set(shading::Param::FullWell, 0.0f), f.params.set(shading::Param::ReadNoise, 0.0f);
                if (!specular) f.params.set(shading::Param::SpecularStrength, 0.0f);
                return session->renderFrameFloat(f);
            };
            if (outputs.linear) *linear = develop(true, true);
            if (outputs.highlight) *highlight = dataset::highlightMask(develop(false, true), develop(false, false));
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
                const frames::Mat4 before = i > 0 ? cameraToWorld(i - 1) : cameraToWorld(i);
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
        truthBytes +=
            static_cast<std::uint64_t>(scene.width) * scene.height * (outputs.linear * 12 + outputs.highlight);
        auto png = std::make_shared<std::vector<std::byte>>();
        if (written == 0) {
            // The first frame is encoded here: its size is the estimate for
            // the rest, and nothing is written before the disk check.
            if (outputs.rgb) *png = encode();
            if (toRender > 1) {
                // Refuse a run whose frames will not fit before writing any
                // of them (x1.25 for frames that compress less well, plus 64
                // MiB to spare).
                const std::uint64_t toWrite = static_cast<std::uint64_t>(toRender);
                // Absolute: the disk probe walks up from the path, and "fly.png" alone has no parent to walk to.
                const std::uint64_t perFrame = png->size() + png->size() / 4 + truthBytes;
                requireDisk(saturatingMul(toWrite, perFrame) + (64ull << 20), fs::absolute(out),
                            fmt::format("{} of ~{}", count(toWrite, "frame"), formatBytes(perFrame)));
            }
            if (frames > 1 && !shard) writeFileAtomic(manifestPath(out), manifest.dump(2) + "\n");
            if (prep.asDataset && !shard)
                writeDatasetManifest(datasetManifestPath(out), out, scene, poses, names, outputs, a.depthScaleMm,
                                     manifest, assets.centerlineTree, lens);
        }
        // The colour frame last: a frame is complete when all its files are.
        // The exposure the camera gave this frame (the modes without a camera: 1).
        const double frameExposure = !photographic ? 1.0
                                     : a.reference ? static_cast<double>(std::exp2(exposure.ev))
                                                   : static_cast<double>(session->renderer().lastExposure());
        writer.push(
            [encode, png, truth, linear, highlight, name, &outputs, scale = a.depthScaleMm, shard, i, frameExposure] {
                if (truth) dataset::writeGroundTruth(*truth, name, outputs, scale);
                auto beside = [&name](const char* suffix) {
                    fs::path p = name;
                    return p.replace_filename(name.stem().string() + suffix);
                };
                if (outputs.linear) image::writeExr(beside(".linear.exr"), *linear, outputs.exrCompression);
                if (outputs.highlight) image::writePng(beside(".highlight.png"), *highlight);
                if (dataset::hasRecord(outputs))
                    writeFileAtomic(dataset::recordFile(name), dataset::frameRecord(i, frameExposure).dump(2) + "\n");
                if (outputs.rgb) writeFileAtomic(name, png->empty() ? encode() : *png);
                if (shard && shard->written) shard->written(i);
            });
        if (truth && outputs.flow) previous = truth, previousIndex = i;
        if (written++ == 0) firstWritten = i;
        lastWritten = i;
        if (frames > 1 && !g.quiet) {
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const double rate = written / std::max(s, 1e-9);
            const int left = toRender - written;
            const std::string line =
                fmt::format("frame {}/{} {}: {} of {} to render ({:.0f}%, {:.1f} frames/s, ETA {})", i + 1, frames,
                            name.filename().string(), written, toRender, 100.0 * written / toRender, rate,
                            formatDuration(left / rate));
            if (tty)
                std::fprintf(stderr, "\r%s\x1b[K", line.c_str());
            else if (written % std::max(1, toRender / 10) == 0 || written == toRender)
                std::fprintf(stderr, "%s\n", line.c_str());
        }
    };
    for (const PlanShard::Segment& s : segments) {
        int lastMissing = -1, firstMissing = s.end;
        for (int i = s.begin; i < s.end; ++i)
            if (!done(i)) lastMissing = i, firstMissing = std::min(firstMissing, i);
        if (lastMissing < 0) continue;
        // Auto-exposure carries state from frame to frame: it starts afresh at
        // the segment's warm-up frame and every frame from there on is
        // rendered (those on disk, or before the segment, are discarded).
        const int start = autoExposure ? std::min(s.warm, firstMissing) : firstMissing;
        restart = true;
        for (int i = start; i <= lastMissing; ++i) {
            if (i < s.begin || done(i)) {
                if (autoExposure) (void)renderFrame(i);
                continue;
            }
            renderAndWrite(i);
        }
    }
    writer.finish();
    if (tty && frames > 1) std::fprintf(stderr, "\n");
    // Every frame is on disk: the manifest again, with each frame's exposure.
    if (prep.asDataset && !shard && dataset::hasRecord(outputs))
        writeDatasetManifest(datasetManifestPath(out), out, scene, poses, names, outputs, a.depthScaleMm, manifest,
                             assets.centerlineTree, lens);
    if (frames == 1 && !shard)
        info(g, fmt::format("wrote {} ({}x{}, mode {})", out.string(), scene.width, scene.height,
                            shading::modeName(scene.mode)));
    else
        info(g, fmt::format("wrote {} of {} .. {} ({}x{}, mode {}){}", count(written, "frame"),
                            names[static_cast<std::size_t>(shard ? firstWritten : 0)].string(),
                            names[static_cast<std::size_t>(shard ? lastWritten : frames - 1)].string(), scene.width,
                            scene.height, shading::modeName(scene.mode),
                            existing ? fmt::format(", kept {} existing", existing) : ""));
}

}  // namespace mucosa::cli
