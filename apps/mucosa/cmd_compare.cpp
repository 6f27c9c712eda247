// mucosa compare: the paper's Figures 2 and 3 as one labelled sheet.
#include <cstdio>

#include <unistd.h>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/render/offscreen.hpp>

#include "scene_options.hpp"

namespace mucosa::cli {

namespace {

struct CompareArgs {
    SceneOptions scene;
    std::string output;
    std::string tile = "400x300";
    int views = 2;
};

void run(const CompareArgs& a, const Global& g) {
    const scene::Scene scene = resolveScene(a.scene);
    if (std::filesystem::path(a.output).extension() != ".png")
        throw InputError("--output", a.output, "must end in .png");
    requireWritable(a.output);
    render::CompareOptions o;
    std::tie(o.tileWidth, o.tileHeight) = parseSize(a.tile, "--tile");
    o.views = a.views;
    const bool tty = isatty(2) && !g.quiet;
    if (tty) o.progress = [](int done, int total) { std::fprintf(stderr, "\rtile %d/%d\x1b[K", done, total); };
    const scene::SceneAssets assets = scene::loadAssets(scene, g.threads);
    for (const std::string& n : assets.notes) info(g, n);
    const image::Image8 sheet = render::compareSheet(scene, assets, o);
    if (tty) std::fprintf(stderr, "\n");
    image::writePng(a.output, sheet);
    info(g, fmt::format("wrote {} ({}x{})", a.output, sheet.width(), sheet.height()));
}

void addCompareCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<CompareArgs>();
    CLI::App* c = app.add_subcommand(
        "compare",
        "The paper's Fig. 2 and 3 as one labelled picture: the same views in every mode, a coarse patch, "
        "and a row varying the noise frequency");
    c->footer("Example: mucosa compare -o sheet.png");
    addSceneOptions(c, a->scene, false);
    c->add_option("-o,--output", a->output, "Output PNG")->required();
    c->add_option("--tile", a->tile, "Size of each picture WxH [400x300]");
    c->add_option("--views", a->views, "Views along the camera path [2]")->check(wholeNumber(1, 8));
    c->callback([a, &g] { run(*a, g); });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(50, addCompareCommand);

}  // namespace mucosa::cli
