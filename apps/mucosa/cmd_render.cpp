// mucosa render: frames of a scene, headless (EGL), to PNG files.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <unistd.h>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>
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
};

void run(const RenderArgs& a, const Global& g) {
    namespace fs = std::filesystem;
    scene::Scene scene = resolveScene(a.scene);
    const int frames = a.frames > 0 ? a.frames : scene.frames;
    const fs::path out = a.output;
    if (out.extension() != ".png") throw InputError("--output", out.string(), "must end in .png");
    requireWritable(out);
    std::vector<fs::path> names;
    for (int i = 0; i < frames; ++i) names.push_back(frames == 1 ? out : render::frameName(out, i));
    // A sequence is resumable: frames already on disk are kept (the writes are
    // atomic, so a file that exists is complete), if the record next to them
    // says they were made with this run's settings.
    const nlohmann::json manifest = frames > 1 ? renderManifest(scene, a.scene, frames, a.reference) : nlohmann::json();
    int existing = 0;
    if (frames > 1 && !a.overwrite)
        for (const fs::path& p : names) existing += fs::exists(p);
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
    while (firstMissing < frames && frames > 1 && !a.overwrite &&
           fs::exists(names[static_cast<std::size_t>(firstMissing)]))
        ++firstMissing;
    constexpr float kSettleTimeConstants = 8.0f;
    const int settleFrames = static_cast<int>(std::ceil(
        kSettleTimeConstants * scene.params[shading::Param::Adaptation] * scene.params[shading::Param::FrameRate]));
    shading::ExposureState exposure;
    auto renderFrame = [&](int i) {
        shading::FrameSetup f = scene::frameSetup(scene, poses[static_cast<std::size_t>(i)], scene.width, scene.height);
        f.frameIndex = i;
        return a.reference ? shading::renderReference(assets.mesh, f, refTextures, &exposure) : session->renderFrame(f);
    };
    for (int i = 0; i < frames; ++i) {
        const fs::path& name = names[static_cast<std::size_t>(i)];
        if (frames > 1 && !a.overwrite && fs::exists(name)) {
            ++skipped;
            // From shortly before the first missing frame on, every frame
            // carries the exposure to the next missing one.
            const bool settle = scene.params[shading::Param::AutoExposure] != 0.0f && i >= firstMissing - settleFrames;
            if (settle) (void)renderFrame(i);
            continue;
        }
        const image::Image8 img = renderFrame(i);
        const std::vector<std::byte> png = image::encodePng(img);
        if (written == 0 && frames - existing > 1) {
            // The first frame encoded is the estimate for the rest: refuse a run
            // whose frames will not fit before writing any of them (x1.25 for
            // frames that compress less well, plus 64 MiB to spare).
            const std::uint64_t toWrite = static_cast<std::uint64_t>(frames - existing);
            // Absolute: the disk probe walks up from the path, and "fly.png" alone has no parent to walk to.
            requireDisk(saturatingMul(toWrite, png.size() + png.size() / 4) + (64ull << 20), fs::absolute(out),
                        fmt::format("{} of ~{}", count(toWrite, "frame"), formatBytes(png.size())));
        }
        if (written == 0 && frames > 1) writeFileAtomic(manifestPath(out), manifest.dump(2) + "\n");
        writeFileAtomic(name, png);
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
    c->callback([a, &g] { run(*a, g); });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(40, addRenderCommand);

}  // namespace mucosa::cli
