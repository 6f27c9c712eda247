#include <mucosa/reflectance/map.hpp>

#include <mucosa/core/error.hpp>

namespace mucosa::reflectance {

namespace {

MapParams make(double frequency, int octaves, double lacunarity, double gain, double strength, bool turbulence,
               const char* name) {
    MapParams p;
    p.noise.frequency = frequency;
    p.noise.octaves = octaves;
    p.noise.lacunarity = lacunarity;
    p.noise.gain = gain;
    p.noise.turbulence = turbulence;
    p.noise.tileable = true;  // maps repeat over meshes: no seams
    p.strength = strength;
    p.preset = name;
    return p;
}

}  // namespace

const std::vector<Preset>& presets() {
    // Strengths are chosen so the mean tilt of the normals (1024^2 map) is
    // ~6 deg (serosa), ~13 deg (bronchial, fine), ~20 deg (rough); docs/cli.md
    // "Presets" shows each.
    static const std::vector<Preset> kPresets = {
        {"bronchial",
         "Bronchial mucosa: fine, dense irregularities that break highlights into many small glints "
         "(the paper's look; default).",
         make(16, 6, 2.0, 0.5, 0.008, false, "bronchial")},
        {"airway",
         "Airway mucosa under its mucus film as a bronchoscope sees it: gentler, larger irregularities, so "
         "highlights are few, larger and elongated over the film's sheen, none glittering at the periphery "
         "(the default scene's map).",
         make(6, 3, 2.0, 0.5, 0.012, false, "airway")},
        {"serosa", "Smooth wet serosa: broad, gentle undulations; highlights stay large and coherent.",
         make(4, 3, 2.0, 0.4, 0.02, false, "serosa")},
        {"rough", "Rough or ridged tissue (inflamed, cobblestoned): turbulence gives creases and sharp ridges.",
         make(8, 5, 2.0, 0.55, 0.022, true, "rough")},
        {"fine",
         "High-frequency variant of bronchial (the paper's Fig. 3, right): same amplitude, 4x the "
         "frequency, highlights shatter into speckle.",
         make(64, 4, 2.0, 0.5, 0.0026, false, "fine")},
    };
    return kPresets;
}

const Preset& findPreset(std::string_view name) {
    std::string known;
    for (const Preset& p : presets()) {
        if (p.name == name) return p;
        known += (known.empty() ? "" : ", ") + p.name;
    }
    throw InputError("preset", "", "unknown preset '" + std::string(name) + "' (known: " + known + ")");
}

}  // namespace mucosa::reflectance
