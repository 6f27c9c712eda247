// mucosa map: the paper's pre-processing stage (noise -> reflectance map).
#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/reflectance/map.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

struct MapArgs {
    std::string output, heightOut, preset, from;
    reflectance::MapParams p;
    bool timings = false;
    CLI::Option *size, *frequency, *octaves, *lacunarity, *gain, *seed, *strength, *turbulence, *tileable, *bits, *z,
        *out, *height;
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
    if (a.size->count()) p.size = a.p.size;
    if (a.frequency->count()) p.noise.frequency = a.p.noise.frequency;
    if (a.octaves->count()) p.noise.octaves = a.p.noise.octaves;
    if (a.lacunarity->count()) p.noise.lacunarity = a.p.noise.lacunarity;
    if (a.gain->count()) p.noise.gain = a.p.noise.gain;
    if (a.seed->count()) p.noise.seed = a.p.noise.seed;
    if (a.z->count()) p.noise.z = a.p.noise.z;
    if (a.strength->count()) p.strength = a.p.strength;
    if (a.turbulence->count()) p.noise.turbulence = a.p.noise.turbulence;
    if (a.tileable->count()) p.noise.tileable = a.p.noise.tileable;
    if (a.bits->count()) p.bits = a.p.bits;
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
    a->size = c->add_option("--size", a->p.size, fmt::format("Map size in texels (square) [{}]", d.size));
    a->frequency = c->add_option("--frequency", a->p.noise.frequency,
                                 fmt::format("Base frequency: noise cycles across the map [{}]", d.noise.frequency));
    a->octaves = c->add_option("--octaves", a->p.noise.octaves, fmt::format("Octaves summed [{}]", d.noise.octaves));
    a->lacunarity = c->add_option("--lacunarity", a->p.noise.lacunarity,
                                  fmt::format("Frequency ratio between octaves [{}]", d.noise.lacunarity));
    a->gain =
        c->add_option("--gain", a->p.noise.gain, fmt::format("Amplitude ratio between octaves [{}]", d.noise.gain));
    a->seed = c->add_option("--seed", a->p.noise.seed, "Permutation seed; 0 = Perlin's reference table [0]");
    a->z = c->add_option("--z", a->p.noise.z,
                         "Slice z of 3D noise that is sampled (avoid integers: lattice creases) [0.5]");
    a->strength = c->add_option("--strength", a->p.strength,
                                fmt::format("Bump strength B: height amplitude in map widths [{}]", d.strength));
    a->turbulence = c->add_flag("--turbulence{true}", a->p.noise.turbulence, "Sum |noise| (ridged) instead of noise");
    a->tileable =
        c->add_flag("--tileable{true}", a->p.noise.tileable,
                    "Periodic noise: the map tiles without a seam (needs whole-number frequency and lacunarity)");
    a->bits = c->add_option("--bits", a->p.bits, "Bits per channel, 8 or 16 [8]");
    a->height = c->add_option("--height-out", a->heightOut, "Also write the height field (.png 16-bit or .exr float)");
    c->add_option("--preset", a->preset, presetHelp());
    c->add_option("--from", a->from, "Regenerate from a sidecar .json (other options override it)");
    c->add_flag("--timings", a->timings, "Print the time of each stage");
    c->callback([a, &g] { run(*a, g); });
}
}  // namespace

MUCOSA_REGISTER_COMMAND(10, addMapCommand);

}  // namespace mucosa::cli
