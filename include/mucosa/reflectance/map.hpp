#pragma once
// The pre-processing stage end to end: fractal noise -> height field ->
// normals -> reflectance map file, with a JSON sidecar that regenerates it.
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include <mucosa/image/image.hpp>
#include <mucosa/noise/fractal.hpp>

namespace mucosa::reflectance {

struct MapParams {
    noise::FractalParams noise;  // frequency = cycles across the whole map
    int size = 1024;             // the map is size x size texels
    double strength = 0.01;      // bump strength B: height amplitude in map widths
    int bits = 8;                // 8 or 16 bits per channel
    std::string preset;          // the preset this came from, if any (informational)
};

// Throws InputError naming the field.
void validate(const MapParams& p);

// The map's parameters, each declared once: the key in scene files
// ("reflectance_map"), sidecars and `--set reflectance_map.<key>`, the option
// of `mucosa map` (--<key>), its range, unit and description, and the viewer's
// slider. Every surface reads this table, so a name or a range is changed in
// one place. (The noise's cross-field rules, e.g. a tileable map's whole
// frequencies, stay in validate().)
enum class MapParam { Size, Frequency, Octaves, Lacunarity, Gain, Seed, Z, Strength, Turbulence, Tileable, Bits };
enum class MapParamKind {
    Integer,  // a whole number in [min, max]
    Real,     // a finite number in [min, max] (above min when minExclusive)
    Seed,     // a whole number in [0, 2^64 - 1]
    Boolean,
};
struct MapParamInfo {
    MapParam id;
    std::string_view name;
    MapParamKind kind;
    double min, max;
    bool minExclusive;
    std::string_view unit;
    std::string_view description;
    double sliderMin, sliderMax;  // the viewer's slider; 0, 0: none
};
inline constexpr int kMapParamCount = 11;
// The largest map a scene generates and renders (one GL texture; every desktop
// GPU and llvmpipe take 8192).
inline constexpr int kMaxRenderedMapSize = 8192;

// The table, in MapParam order.
std::span<const MapParamInfo> mapRegistry() noexcept;
const MapParamInfo& info(MapParam p) noexcept;
const MapParamInfo* findMapParam(std::string_view name) noexcept;  // nullptr if unknown
// The value as a double (seeds above 2^53 lose precision: for display only).
double get(const MapParams& p, MapParam id) noexcept;
// Sets one parameter from a JSON value of its kind, checking the range.
// Throws InputError(subject, file, why): a wrong type, a fraction where a
// whole number is needed, out of range (no wrap, no truncation).
void set(MapParams& p, MapParam id, const nlohmann::json& value, const std::string& subject,
         const std::string& file = "");
// A value as options and --set give it: "true" and "false" as booleans, a
// finite JSON number as a number (whole numbers stay whole), anything else
// (a preset name, "1e999") as a string.
nlohmann::json parameterValue(std::string_view text);
// set() from text ("32", "0.5", "true"); a string is refused.
void setFromText(MapParams& p, MapParam id, std::string_view text, const std::string& subject,
                 const std::string& file = "");
// One line per parameter for help: "--name (unit, min..max, default d): description".
std::string mapRegistryHelp();

struct Preset {
    std::string name, description;
    MapParams params;
};
// Documented tissue looks (docs/cli.md, mucosa map, "Presets").
const std::vector<Preset>& presets();
// Throws InputError("preset", ...) listing the known names.
const Preset& findPreset(std::string_view name);

// Bytes the whole pipeline needs at peak for these parameters (saturating).
std::uint64_t mapMemoryBytes(const MapParams& p, bool withHeight);

// Height field (1 channel float) by the fast path.
image::ImageF heightField(const MapParams& p, int threads = 0);

enum class HeightFormat { Png16, Exr };

struct MapOutputs {
    std::filesystem::path map;                    // PNG
    std::optional<std::filesystem::path> height;  // .png (16-bit) or .exr
    bool sidecar = true;                          // <map>.json next to the map
};

struct MapReport {
    // encodeSeconds: normals, PNG filter and deflate, streamed together in
    // bands of rows (the whole encoded map never exists in memory).
    double noiseSeconds = 0, encodeSeconds = 0, writeSeconds = 0;
    std::uint64_t mapBytes = 0;
    int resolvableOctaves = 0;
    std::vector<std::string> warnings;
    std::filesystem::path sidecar;
    float heightMin = 0, heightMax = 0;
};

// Generates and writes everything atomically. Checks parameters, output
// paths and memory before doing any work.
MapReport generateMap(const MapParams& p, const MapOutputs& out, int threads = 0);

// Sidecar file: <map path with .json extension>.
std::filesystem::path sidecarPath(const std::filesystem::path& map);

// JSON round trip of the parameters (the "params" object of a sidecar).
nlohmann::json toJson(const MapParams& p);
// Throws InputError naming `file` and the field.
MapParams mapParamsFromJson(const nlohmann::json& j, const std::string& file);

struct Sidecar {
    MapParams params;
    std::filesystem::path map;  // resolved against the sidecar's folder
    std::optional<std::filesystem::path> height;
};
Sidecar readSidecar(const std::filesystem::path& path);

}  // namespace mucosa::reflectance
