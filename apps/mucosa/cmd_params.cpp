// mucosa params: the shading modes and the parameter registry, the one list
// render, compare and view (--mode, --set) and scene files read.
#include <algorithm>
#include <cstdio>

#include <fmt/format.h>

#include <mucosa/reflectance/appearance.hpp>
#include <mucosa/shading/params.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

std::string paramsText() {
    std::string s = "Shading modes (--mode NAME, or \"mode\" in a scene file):\n";
    std::size_t width = 0;
    for (const shading::ModeInfo& m : shading::modes()) width = std::max(width, m.name.size());
    for (const shading::ModeInfo& m : shading::modes())
        s += fmt::format("  {:<{}}  {}\n", m.name, width, m.description);
    s += "\nParameters (--set group.name=value, or the scene file's \"material\", \"brdf\", \"light\" and \"camera\" "
         "objects; "
         "colours r,g,b):\n";
    s += shading::registryHelp();
    s += "\nReflectance map (--set reflectance_map.KEY=VALUE): the keys of a scene's \"reflectance_map\" object, "
         "the options of mucosa map (docs/scene-format.md).\n";
    s += "\nGenerated tissue texture (--set tissue.KEY=VALUE, or the scene file's \"tissue\" object; over the "
         "patient's draw with --variation):\n";
    const reflectance::TissueParams defaults = reflectance::defaultAppearance().tissue;
    for (const reflectance::TissueParamInfo& i : reflectance::tissueRegistry())
        s += fmt::format("  tissue.{} ({}{}{}..{}, default {}): {}\n", i.name, i.unit, i.unit.empty() ? "" : ", ",
                         i.min, i.max, defaults.*i.member, i.meaning);
    return s;
}

void addParamsCommand(CLI::App& app, Global& g) {
    CLI::App* c = app.add_subcommand(
        "params", "List the shading modes and every shading parameter (name, unit, range, default, description)");
    c->footer(
        "Example: mucosa params\nThen: mucosa render -o frame.png --mode vertex-phong --set material.shininess=80");
    c->callback([&g] {
        if (!g.quiet) std::fputs(paramsText().c_str(), stdout);
    });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(65, addParamsCommand);

}  // namespace mucosa::cli
