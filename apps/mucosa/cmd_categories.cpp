// mucosa categories: the user study's five image categories per registered pose.
#include <unistd.h>

#include <cstdio>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/fit/categories.hpp>
#include <mucosa/mesh/io.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

struct CategoriesArgs {
    std::string mesh, fitDir, frames, out;
    fit::CategoriesOptions o;
};

void addCategoriesCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<CategoriesArgs>();
    CLI::App* c = app.add_subcommand(
        "categories", "Render the study's categories 1-4 at every frame's pose and copy the real frame as category 5");
    c->footer(
        "Example: mucosa categories --mesh airway_uv.glb --fit fit/ --frames frames.json -o stimuli/\n"
        "Then: mucosa study plan --manifest stimuli/images.json -o study.json");
    c->add_option("--mesh", a->mesh, "The mesh the fit used")->required();
    c->add_option("--fit", a->fitDir, "The output folder of mucosa fit (brdf.json, texture.png)")->required();
    c->add_option("--frames", a->frames, "Frames file (poses and intrinsics)")->required();
    c->add_option("-o,--output", a->out, "Output folder (images + images.json)")->required();
    c->add_option("--patient", a->o.patient, "Patient label in the manifest [patient]");
    c->add_option("--low-res", a->o.lowResDivisor, "Category 2: reduce the texture by this factor [8]")
        ->check(wholeNumber(2, 256));
    c->add_option("--preset", a->o.preset, "Reflectance-map preset of category 4 [bronchial]");
    c->add_option("--map-tiling", a->o.mapTiling, "Map repeats per unit of texture coordinate [4]");
    c->callback([a, &g] {
        a->o.threads = g.threads;
        requireOutputDir(a->out);
        const bool tty = ::isatty(STDERR_FILENO) != 0;
        if (!g.quiet)
            a->o.progress = [tty](int done, int total) {
                std::fprintf(stderr, tty ? "\r[categories] pose %d/%d" : "[categories] pose %d/%d\n", done, total);
                if (tty && done == total) std::fprintf(stderr, "\n");
            };
        const frames::FrameSet frames = frames::readFrames(a->frames);
        const fit::FittedModel model = fit::readFitDirectory(a->fitDir);
        const mesh::Mesh m = mesh::load(a->mesh);
        const auto images = fit::renderCategories(m, frames, model, a->out, a->o);
        info(g, fmt::format("wrote {} ({} x 5 categories) and {}", count(images.size(), "image"),
                            count(images.size() / 5, "pose"), joinPath(a->out, "images.json")));
    });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(80, addCategoriesCommand);

}  // namespace mucosa::cli
