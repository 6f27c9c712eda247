// mucosa phantom: the built-in airway phantom (mesh + centerline JSON).
#include <chrono>
#include <cstdio>
#include <optional>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/phantom.hpp>
#include <mucosa/scene/gltf_export.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

struct PhantomArgs {
    std::string output = "airway.glb", centerline, material = "mucosa", look;
    mesh::PhantomParams p;
    bool noRings = false;
};

void addPhantomCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<PhantomArgs>();
    CLI::App* c =
        app.add_subcommand("phantom", "Generate the synthetic airway phantom (bronchial tree mesh + centerline JSON)");
    c->footer(
        "Example: mucosa phantom -o airway.glb --generations 3 --seed 1\n"
        "Millimetres; origin at the top of the trachea, +Y up (cranial), +X the patient's left, +Z anterior.\n"
        "Normals face the lumen. The centerline tree (points, radii, parent links) goes to OUT.centerline.json.");
    const mesh::PhantomParams d;
    c->add_option("-o,--output", a->output, "Output mesh (.glb, .gltf, .ply, .obj) [airway.glb]");
    c->add_option("--generations", a->p.generations,
                  fmt::format("Airway generations below the trachea: 1 main, 2 lobar, 3 segmental, ... (0..7) [{}]",
                              d.generations));
    c->add_option("--seed", a->p.seed, fmt::format("Seed of the branching jitter [{}]", d.seed));
    c->add_option("--resolution", a->p.resolution,
                  fmt::format("Grid cells per millimetre of the implicit surface (0.25..16) [{}]", d.resolution));
    c->add_option("--centerline", a->centerline, "Centerline JSON path [OUT with .centerline.json]");
    c->add_flag("--no-rings", a->noRings, "Smooth walls without cartilage ring ridges");
    c->add_option("--material", a->material,
                  "glTF output's material: mucosa (the wet look: subject texture, reflectance map on a clearcoat, "
                  "docs/engines.md) or plain (one untextured tissue colour) [mucosa]");
    c->add_option(
        "--look", a->look,
        "Mucosa's material from this scene file (material, diffuse, reflectance_map) or look file (mucosa look fit)");
    c->callback([a, &g] {
        const mesh::FileFormat format = mesh::outputFormat(a->output);
        const bool gltf = format == mesh::FileFormat::Glb || format == mesh::FileFormat::Gltf;
        if (a->material != "mucosa" && a->material != "plain")
            throw InputError("--material", "", fmt::format("'{}' is not one of mucosa, plain", a->material));
        if (!a->look.empty() && a->material != "mucosa")
            throw InputError("--look", "", "--look gives Mucosa's material; it contradicts --material plain");
        if (!a->look.empty() && !gltf)
            throw InputError("--look", a->output, "materials are written to .glb and .gltf only");
        // The look's scene is read before the long part, so a bad one fails at once.
        const scene::Scene lookScene = a->look.empty() ? scene::defaultScene() : scene::loadSceneOrLook(a->look);
        requireWritable(a->output);
        std::filesystem::path cl = a->centerline;
        if (cl.empty()) cl = std::filesystem::path(a->output).replace_extension(".centerline.json");
        requireWritable(cl);
        a->p.cartilageRings = !a->noRings;
        const auto t0 = std::chrono::steady_clock::now();
        auto progress = [&](double f, std::string_view stage) {
            if (g.quiet) return;
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            std::fprintf(stderr, "[%6.2f s] %3.0f%% %.*s\n", s, 100 * f, static_cast<int>(stage.size()), stage.data());
        };
        const mesh::Phantom ph = mesh::makePhantom(a->p, g.threads, progress);
        mesh::SaveOptions so;
        so.name = "airway phantom";
        std::optional<mesh::GltfLook> look;
        if (gltf) {
            // Watertight with normals facing the lumen: seen from inside, double-sided.
            const bool doubleSided = scene::gltfDoubleSided(ph.mesh);
            if (a->material == "mucosa") {
                progress(1.0, "textures");
                scene::SceneAssets assets;
                scene::loadTextures(lookScene, assets, g.threads);
                look = scene::gltfLook(lookScene, assets, doubleSided);
            } else {
                look = scene::plainGltfLook(lookScene.params, doubleSided);
                warn(
                    "the plain material reads no texture: TEXCOORD_0 is written for your own (validators note it "
                    "as unused)");
            }
            so.look = &*look;
        }
        mesh::save(ph.mesh, a->output, so);
        mesh::writeCenterlineJson(ph.centerline, cl);
        const mesh::MeshReport r = mesh::analyze(ph.mesh);
        info(g, fmt::format("wrote {} ({}, {}, {:.0f} x {:.0f} x {:.0f} mm, {})", a->output,
                            count(r.vertices, "vertex", "vertices"), count(r.triangles, "triangle"),
                            r.boundsMax[0] - r.boundsMin[0], r.boundsMax[1] - r.boundsMin[1],
                            r.boundsMax[2] - r.boundsMin[2], r.watertight() ? "watertight" : "NOT watertight"));
        info(g, fmt::format("wrote {} ({})", cl.string(), count(ph.centerline.branches.size(), "branch", "branches")));
    });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(30, addPhantomCommand);

}  // namespace mucosa::cli
