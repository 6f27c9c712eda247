// mucosa view: the interactive viewer (GLFW window + Dear ImGui panels).
#include <fmt/format.h>

#include <mucosa/render/viewer.hpp>

#include "scene_options.hpp"

namespace mucosa::cli {

namespace {

struct ViewArgs {
    SceneOptions scene;
    std::string window = "1280x800";
    int frames = 0;
    std::string screenshot;
    bool noAutoplay = false;
};

void run(const ViewArgs& a, const Global& g) {
    scene::Scene scene = resolveScene(a.scene);
    render::ViewerOptions o;
    std::tie(o.width, o.height) = parseSize(a.window, "--window");
    o.maxFrames = a.frames;
    o.autoplay = !a.noAutoplay;
    if (!a.screenshot.empty()) o.screenshot = a.screenshot;
    if (a.frames > 0) o.vsync = false;
    scene::SceneAssets assets = scene::loadAssets(scene, g.threads);
    for (const std::string& n : assets.notes) info(g, n);
    const render::ViewerReport r = render::runViewer(std::move(scene), std::move(assets), o);
    info(g, fmt::format("{}, {:.1f} fps on average ({})", count(r.frames, "frame"), r.meanFps, r.glRenderer));
    if (o.screenshot) info(g, "wrote " + o.screenshot->string());
}

void addViewCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<ViewArgs>();
    CLI::App* c = app.add_subcommand(
        "view", "Interactive viewer: fly through the airway, change the mode and every parameter live (needs X)");
    c->footer("Controls:\n" + render::viewerControls() + "\nExample: mucosa view scene.json");
    addSceneOptions(c, a->scene, false);
    c->add_option("--window", a->window, "Window size WxH [1280x800]");
    c->add_flag("--no-autoplay", a->noAutoplay, "Start paused (Space plays the fly-through)");
    c->add_option("--frames", a->frames, "Close after N frames (scripted runs)")->check(wholeNumber(1));
    c->add_option("--screenshot", a->screenshot, "With --frames: save the last frame, panels included, to this PNG");
    c->callback([a, &g] { run(*a, g); });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(60, addViewCommand);

}  // namespace mucosa::cli
