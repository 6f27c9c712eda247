// mucosa demo: the main job on the built-in default, written to ./out/.
#include <filesystem>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/render/offscreen.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {
void addDemoCommand(CLI::App& app, Global& g) {
    auto outDir = std::make_shared<std::string>("out");
    CLI::App* c =
        app.add_subcommand("demo", "Run the whole pipeline on the built-in default and write results to ./out/");
    c->add_option("-o,--output-dir", *outDir, "Output folder, created if its parent exists [out]");
    c->callback([outDir, &g] {
        namespace fs = std::filesystem;
        const fs::path dir = *outDir;
        // As every other command's output: the folder is created, its parents must exist.
        requireOutputDir(dir);
        std::error_code ec;
        fs::create_directory(dir, ec);
        if (ec) throw IoError("output folder", dir.string(), ec.message());
        const reflectance::Preset& preset = reflectance::findPreset("bronchial");
        reflectance::MapOutputs out;
        out.map = dir / "reflectance_map.png";
        out.height = dir / "height.png";
        const reflectance::MapReport r = reflectance::generateMap(preset.params, out, g.threads);
        for (const std::string& w : r.warnings) warn(w);
        info(g, fmt::format("demo: '{}' preset, {}x{} texels", preset.name, preset.params.size, preset.params.size));
        info(g, fmt::format("  reflectance map: {}", fs::absolute(out.map).lexically_normal().string()));
        info(g, fmt::format("  height map:      {}", fs::absolute(*out.height).lexically_normal().string()));
        info(g, fmt::format("  parameters:      {}", fs::absolute(r.sidecar).lexically_normal().string()));
        render::writeDefaultCompareSheet(dir / "compare.png", g.threads);  // the paper's Fig. 2 and 3
        info(g, fmt::format("  comparison:      {}", fs::absolute(dir / "compare.png").lexically_normal().string()));
    });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(100, addDemoCommand);

}  // namespace mucosa::cli
