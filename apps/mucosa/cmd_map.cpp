// mucosa map: the paper's pre-processing stage (noise -> reflectance map).
#include <array>
#include <cctype>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/reflectance/map.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

struct MapArgs {
    std::string output, heightOut, preset, from;
    // One option per map parameter (reflectance::mapRegistry()), as text: the
    // registry parses and range-checks it (no wrap: --seed -1 is refused).
    std::array<std::string, reflectance::kMapParamCount> values;
    std::array<CLI::Option*, reflectance::kMapParamCount> options{};
    bool timings = false;
    CLI::Option *out, *height;
};

std::string presetHelp() {
    std::string s = "Start from a tissue preset:";
    for (const auto& p : reflectance::presets()) s += "\n  " + p.name + ": " + p.description;
    return s;
}

void run(MapArgs& a, const Global& g) {
    reflectance::MapParams p;
    reflectance::MapOutputs out;
    if (!a.from.empty()) {
        const reflectance::Sidecar s = reflectance::readSidecar(a.from);
        p = s.params;
        out.map = s.map;
        if (!a.out->count() && !a.height->count()) out.height = s.height;
    } else if (!a.preset.empty()) {
        p = reflectance::findPreset(a.preset).params;
    }
    if (!a.preset.empty() && !a.from.empty()) p = reflectance::findPreset(a.preset).params;
    // Explicit options override the preset or sidecar.
    for (const reflectance::MapParamInfo& i : reflectance::mapRegistry()) {
        const auto k = static_cast<std::size_t>(i.id);
        if (a.options[k]->count()) reflectance::setFromText(p, i.id, a.values[k], "--" + std::string(i.name));
    }
    if (a.out->count()) out.map = a.output;
    if (a.height->count()) out.height = a.heightOut;
    if (out.map.empty()) throw InputError("output", "", "give -o FILE.png (or --from a sidecar)");

    const reflectance::MapReport r = reflectance::generateMap(p, out, g.threads);
    for (const std::string& w : r.warnings) warn(w);
    info(g, fmt::format("wrote {} ({}x{}, {}-bit, {} bytes)", out.map.string(), p.size, p.size, p.bits, r.mapBytes));
    if (out.height) info(g, fmt::format("wrote {} (height field)", out.height->string()));
    if (!r.sidecar.empty()) info(g, fmt::format("wrote {} (parameters; regenerate with --from)", r.sidecar.string()));
    if (a.timings)
        info(g, fmt::format("timings: noise {:.3f} s, normals + png encode {:.3f} s, write {:.3f} s, total {:.3f} s",
                            r.noiseSeconds, r.encodeSeconds, r.writeSeconds,
                            r.noiseSeconds + r.encodeSeconds + r.writeSeconds));
}

}  // namespace

namespace {
void addMapCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<MapArgs>();
    CLI::App* c = app.add_subcommand("map", "Generate a reflectance map (Perlin noise -> height -> normals -> RGB)");
    c->footer("Example: mucosa map -o map.png --preset bronchial --size 2048 --height-out height.exr");
    const reflectance::MapParams d;
    a->out =
        c->add_option("-o,--output", a->output, "Output reflectance map (.png); a .json sidecar is written next to it");
    for (const reflectance::MapParamInfo& i : reflectance::mapRegistry()) {
        const auto k = static_cast<std::size_t>(i.id);
        const std::string name = "--" + std::string(i.name);
        const double v = reflectance::get(d, i.id);
        const bool flag = i.kind == reflectance::MapParamKind::Boolean;
        const std::string help =
            fmt::format("{}{} [{}]", static_cast<char>(std::toupper(i.description[0])), i.description.substr(1),
                        flag ? (v != 0 ? "on" : "off") : fmt::format("{}", v));
        // Booleans are flags (--tileable, or --tileable=false); the rest take a value of the registry's kind.
        if (flag) {
            a->options[k] = c->add_flag(name + "{true}", a->values[k], help);
        } else {
            a->options[k] = c->add_option(name, a->values[k], help);
            a->options[k]->type_name(i.kind == reflectance::MapParamKind::Real ? "NUMBER" : "INT");
        }
    }
    a->height = c->add_option("--height-out", a->heightOut, "Also write the height field (.png 16-bit or .exr float)");
    c->add_option("--preset", a->preset, presetHelp());
    c->add_option("--from", a->from, "Regenerate from a sidecar .json (other options override it)");
    c->add_flag("--timings", a->timings, "Print the time of each stage");
    c->callback([a, &g] { run(*a, g); });
}
}  // namespace

MUCOSA_REGISTER_COMMAND(10, addMapCommand);

}  // namespace mucosa::cli
