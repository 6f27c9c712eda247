#include <mucosa/reflectance/map.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/core/version.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/reflectance/normal_map.hpp>

#include "core/json_parse.hpp"

namespace mucosa::reflectance {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr int kMaxSize = 1 << 20;

using K = MapParamKind;
constexpr double kInf = std::numeric_limits<double>::infinity();
// name, kind, min, max, min exclusive, unit, description, viewer slider
constexpr std::array<MapParamInfo, kMapParamCount> kMapRegistry = {{
    {MapParam::Size, "size", K::Integer, 1, kMaxSize, false, "texels", "map size (square)", 0, 0},
    {MapParam::Frequency, "frequency", K::Real, 0, kInf, true, "cycles per map", "base frequency: noise cycles across the map", 1, 128},
    {MapParam::Octaves, "octaves", K::Integer, 1, 32, false, "", "octaves summed", 1, 12},
    {MapParam::Lacunarity, "lacunarity", K::Real, 0, kInf, true, "", "frequency ratio between octaves", 0, 0},
    {MapParam::Gain, "gain", K::Real, 0, kInf, false, "", "amplitude ratio between octaves", 0, 0},
    {MapParam::Seed, "seed", K::Seed, 0, 18446744073709551615.0, false, "", "permutation seed; 0 = Perlin's reference table", 0, 0},
    {MapParam::Z, "z", K::Real, -kInf, kInf, false, "", "slice z of 3D noise that is sampled (avoid integers: lattice creases)", 0, 0},
    {MapParam::Strength, "strength", K::Real, 0, kInf, false, "map widths", "bump strength B: height amplitude in map widths", 0.0005, 0.05},
    {MapParam::Turbulence, "turbulence", K::Boolean, 0, 1, false, "", "sum |noise| (ridged) instead of noise", 0, 0},
    {MapParam::Tileable, "tileable", K::Boolean, 0, 1, false, "", "periodic noise: the map tiles without a seam (whole-number frequency and lacunarity)", 0, 0},
    {MapParam::Bits, "bits", K::Integer, 8, 16, false, "", "bits per channel, 8 or 16", 0, 0},
}};

double seconds(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

}  // namespace

std::span<const MapParamInfo> mapRegistry() noexcept {
    return kMapRegistry;
}

const MapParamInfo& info(MapParam p) noexcept {
    return kMapRegistry[static_cast<std::size_t>(p)];
}

const MapParamInfo* findMapParam(std::string_view name) noexcept {
    for (const MapParamInfo& i : kMapRegistry)
        if (i.name == name) return &i;
    return nullptr;
}

double get(const MapParams& p, MapParam id) noexcept {
    switch (id) {
        case MapParam::Size: return p.size;
        case MapParam::Frequency: return p.noise.frequency;
        case MapParam::Octaves: return p.noise.octaves;
        case MapParam::Lacunarity: return p.noise.lacunarity;
        case MapParam::Gain: return p.noise.gain;
        case MapParam::Seed: return static_cast<double>(p.noise.seed);
        case MapParam::Z: return p.noise.z;
        case MapParam::Strength: return p.strength;
        case MapParam::Turbulence: return p.noise.turbulence ? 1 : 0;
        case MapParam::Tileable: return p.noise.tileable ? 1 : 0;
        case MapParam::Bits: return p.bits;
    }
    return 0;
}

namespace {

// Why `v` is out of `i`'s range, in the words of the old checks.
std::string outOfRange(const MapParamInfo& i, const std::string& v) {
    if (i.kind == K::Seed) return fmt::format("must be a whole number in 0..2^64-1, got {}", v);
    if (i.kind == K::Integer) return fmt::format("must be in {}..{}, got {}", i.min, i.max, v);
    if (i.max == kInf && i.min == 0)
        return i.minExclusive ? fmt::format("must be a positive number, got {}", v)
                              : fmt::format("must be a number >= 0, got {}", v);
    return fmt::format("must be in [{}, {}], got {}", i.min, i.max, v);
}

// The range as help text: "1..32", "> 0", ">= 0", "any".
std::string rangeText(const MapParamInfo& i) {
    if (i.kind == K::Seed) return "0..2^64-1";
    if (i.max == kInf) return i.min == -kInf ? "any" : fmt::format("{} {}", i.minExclusive ? ">" : ">=", i.min);
    return fmt::format("{}..{}", i.min, i.max);
}

}  // namespace

void set(MapParams& p, MapParam id, const json& v, const std::string& subject, const std::string& file) {
    const MapParamInfo& i = info(id);
    auto fail = [&](const std::string& why) { throw InputError(subject, file, why); };
    switch (i.kind) {
        case K::Boolean: {
            if (!v.is_boolean()) fail(std::string("must be true or false, not ") + v.type_name());
            const bool b = v.get<bool>();
            (id == MapParam::Turbulence ? p.noise.turbulence : p.noise.tileable) = b;
            return;
        }
        case K::Seed:
        case K::Integer: {
            if (!v.is_number()) fail(std::string("must be a whole number, not ") + v.type_name());
            std::uint64_t u = 0;
            std::int64_t n = 0;
            if (v.is_number_float()) {
                const double d = v.get<double>();
                if (!std::isfinite(d) || d != std::floor(d)) fail(fmt::format("must be a whole number, not {}", d));
                if (d < i.min || d > i.max) fail(outOfRange(i, fmt::format("{}", d)));
                u = static_cast<std::uint64_t>(std::max(d, 0.0));
                n = d < 9.2e18 ? static_cast<std::int64_t>(d) : 0;
            } else if (v.is_number_unsigned()) {
                u = v.get<std::uint64_t>();
                if (i.kind == K::Integer && u > static_cast<std::uint64_t>(i.max))
                    fail(outOfRange(i, std::to_string(u)));
                n = static_cast<std::int64_t>(std::min<std::uint64_t>(u, 1ull << 62));
            } else {
                n = v.get<std::int64_t>();
                if (static_cast<double>(n) < i.min || static_cast<double>(n) > i.max)
                    fail(outOfRange(i, std::to_string(n)));
                u = static_cast<std::uint64_t>(n);
            }
            switch (id) {
                case MapParam::Size: p.size = static_cast<int>(n); break;
                case MapParam::Octaves: p.noise.octaves = static_cast<int>(n); break;
                case MapParam::Bits: p.bits = static_cast<int>(n); break;
                case MapParam::Seed: p.noise.seed = u; break;
                default: MUCOSA_CHECK(false, "a whole-number map parameter without a field");
            }
            return;
        }
        case K::Real: {
            if (!v.is_number()) fail(std::string("must be a number, not ") + v.type_name());
            const double d = v.get<double>();
            if (!std::isfinite(d)) fail("must be finite");
            if (d < i.min || d > i.max || (i.minExclusive && d == i.min))
                fail(outOfRange(i, fmt::format("{}", d)));
            switch (id) {
                case MapParam::Frequency: p.noise.frequency = d; break;
                case MapParam::Lacunarity: p.noise.lacunarity = d; break;
                case MapParam::Gain: p.noise.gain = d; break;
                case MapParam::Z: p.noise.z = d; break;
                case MapParam::Strength: p.strength = d; break;
                default: MUCOSA_CHECK(false, "a real map parameter without a field");
            }
            return;
        }
    }
}

json parameterValue(std::string_view text) {
    if (text == "true" || text == "false") return text == "true";
    try {
        json v = json::parse(text);
        if (v.is_number() && (!v.is_number_float() || std::isfinite(v.get<double>()))) return v;
    } catch (const json::exception&) {  // not JSON, or a number out of range
    }
    return std::string(text);
}

void setFromText(MapParams& p, MapParam id, std::string_view text, const std::string& subject,
                 const std::string& file) {
    const json v = parameterValue(text);
    if (v.is_string()) throw InputError(subject, file, fmt::format("'{}' is not a {}", text,
                                                                    info(id).kind == K::Boolean ? "true or false"
                                                                                                 : "number"));
    set(p, id, v, subject, file);
}

std::string mapRegistryHelp() {
    const MapParams d;
    std::string s;
    for (const MapParamInfo& i : kMapRegistry) {
        std::string def = i.kind == K::Boolean ? (get(d, i.id) != 0 ? "true" : "false") : fmt::format("{}", get(d, i.id));
        s += fmt::format("  {} ({}{}, default {}): {}\n", i.name, i.unit.empty() ? "" : std::string(i.unit) + ", ",
                         i.kind == K::Boolean ? "true/false" : rangeText(i), def, i.description);
    }
    return s;
}

void validate(const MapParams& p) {
    // The registry's ranges, then the rules that tie parameters together.
    for (const MapParamInfo& i : kMapRegistry) {
        if (i.kind == K::Boolean || i.kind == K::Seed) continue;
        const double v = get(p, i.id);
        const std::string name(i.name);
        if (!std::isfinite(v) && i.max != kInf) throw InputError(name, "", "must be finite");
        if (v < i.min || v > i.max || (i.minExclusive && v == i.min))
            throw InputError(name, "", outOfRange(i, fmt::format("{}", v)));
    }
    if (p.bits != 8 && p.bits != 16) throw InputError("bits", "", fmt::format("must be 8 or 16, got {}", p.bits));
    noise::validate(p.noise);
}

std::uint64_t mapMemoryBytes(const MapParams& p, bool withHeight) {
    // Height (float) + the PNG encoder's compressed pieces, the joined stream
    // and the file's bytes (each at most ~1.125x the 3b bytes per texel of the
    // encoded map); the normals themselves are streamed, never held whole.
    const std::uint64_t px = saturatingMul(static_cast<std::uint64_t>(p.size), static_cast<std::uint64_t>(p.size));
    const std::uint64_t b = static_cast<std::uint64_t>(p.bits / 8);
    std::uint64_t perPixel = 4 + 11 * b;
    if (withHeight) perPixel += 4 * 2;
    return saturatingMul(px, perPixel);
}

image::ImageF heightField(const MapParams& p, int threads) {
    validate(p);
    image::ImageF H(p.size, p.size, 1);
    noise::fillFractal(p.noise, H.span(), p.size, p.size, {threads});
    return H;
}

fs::path sidecarPath(const fs::path& map) {
    fs::path s = map;
    s.replace_extension(".json");
    return s;
}

json toJson(const MapParams& p) {
    return json{{"size", p.size},
                {"frequency", p.noise.frequency},
                {"octaves", p.noise.octaves},
                {"lacunarity", p.noise.lacunarity},
                {"gain", p.noise.gain},
                {"seed", p.noise.seed},
                {"z", p.noise.z},
                {"turbulence", p.noise.turbulence},
                {"tileable", p.noise.tileable},
                {"strength", p.strength},
                {"bits", p.bits},
                {"preset", p.preset}};
}

MapParams mapParamsFromJson(const json& j, const std::string& file) {
    if (!j.is_object()) throw InputError("params", file, "must be a JSON object");
    MapParams p;
    for (const auto& [key, value] : j.items()) {
        const std::string subject = "field '" + key + "'";
        if (key == "preset") {
            if (!value.is_string()) throw InputError(subject, file, "must be a string");
            p.preset = value.get<std::string>();
        } else if (const MapParamInfo* i = findMapParam(key)) {
            set(p, i->id, value, subject, file);
        } else {
            std::string known = "preset";
            for (const MapParamInfo& r : kMapRegistry) known += ", " + std::string(r.name);
            throw InputError(subject, file, fmt::format("is not a map parameter (known: {})", known));
        }
    }
    try {
        validate(p);
    } catch (const InputError& e) {
        throw InputError("field '" + e.subject() + "'", file, e.reason());
    }
    return p;
}

Sidecar readSidecar(const fs::path& path) {
    const std::string text = readTextFile(path);
    const json j = detail::parseJsonFile(text, path.string());
    if (!j.is_object() || !j.contains("params"))
        throw InputError("field 'params'", path.string(), "missing: not a Mucosa map sidecar");
    Sidecar s;
    s.params = mapParamsFromJson(j["params"], path.string());
    const fs::path dir = path.parent_path();
    if (j.contains("outputs") && j["outputs"].is_object()) {
        const json& o = j["outputs"];
        // Outputs are written beside the sidecar only: a sidecar from elsewhere
        // must not be able to overwrite files outside its folder.
        auto output = [&](const char* key) -> std::optional<fs::path> {
            if (!o.contains(key)) return std::nullopt;
            if (!o[key].is_string())
                throw InputError(fmt::format("field 'outputs.{}'", key), path.string(), "must be a file name");
            const std::string name = o[key].get<std::string>();
            auto confined = confinedPath(dir, name);
            if (!confined)
                throw InputError(fmt::format("field 'outputs.{}'", key), path.string(),
                                 fmt::format("'{}' is not a file inside the sidecar's folder (outputs are written "
                                             "beside the sidecar only)",
                                             name.substr(0, 200)));
            return confined;
        };
        if (auto m = output("map")) s.map = *m;
        s.height = output("height");
    }
    if (s.map.empty()) {
        s.map = path;
        s.map.replace_extension(".png");
    }
    return s;
}

MapReport generateMap(const MapParams& p, const MapOutputs& out, int threads) {
    validate(p);
    MapReport report;
    const std::string mapExt = lower(out.map.extension().string());
    if (mapExt != ".png") throw InputError("output", out.map.string(), "the reflectance map is written as .png");
    HeightFormat hf = HeightFormat::Png16;
    if (out.height) {
        const std::string e = lower(out.height->extension().string());
        if (e == ".exr")
            hf = HeightFormat::Exr;
        else if (e != ".png")
            throw InputError("height output", out.height->string(), "must end in .png or .exr");
        if (fs::weakly_canonical(*out.height) == fs::weakly_canonical(out.map))
            throw InputError("height output", out.height->string(), "is the same file as the map");
    }
    // Fail before any work: paths, then memory.
    requireWritable(out.map);
    if (out.height) requireWritable(*out.height);
    if (out.sidecar) requireWritable(sidecarPath(out.map));
    requireMemory(mapMemoryBytes(p, out.height.has_value()), fmt::format("a {0}x{0} map", p.size));

    report.resolvableOctaves = noise::resolvableOctaves(p.noise, p.size);
    if (report.resolvableOctaves < p.noise.octaves)
        report.warnings.push_back(fmt::format(
            "octaves: only {} of {} octaves are resolvable at size {} (octave frequency must be <= size/2 = {}); "
            "the finer ones alias",
            report.resolvableOctaves, p.noise.octaves, p.size, p.size / 2));

    auto t0 = std::chrono::steady_clock::now();
    image::ImageF H = heightField(p, threads);
    report.noiseSeconds = seconds(t0);
    const auto [mn, mx] = std::minmax_element(H.data(), H.data() + H.size());
    report.heightMin = *mn;
    report.heightMax = *mx;

    const Edges edges = p.noise.tileable ? Edges::Wrap : Edges::Clamp;
    image::PngWriteOptions png;
    png.threads = threads;
    // Normals are computed band by band inside the PNG encoder (same bytes as
    // encodeNormals8/16 then encodePng, without holding the encoded map).
    t0 = std::chrono::steady_clock::now();
    image::PngRowSource rows{p.size, p.size, 3, p.bits, {}};
    if (p.bits == 8) {
        rows.row = [&](int y, std::uint8_t* dst) { encodeNormalRow8(H, y, p.strength, edges, dst); };
    } else {
        rows.row = [&](int y, std::uint8_t* dst) {
            thread_local std::vector<std::uint16_t> samples;
            samples.resize(static_cast<std::size_t>(3) * static_cast<std::size_t>(p.size));
            encodeNormalRow16(H, y, p.strength, edges, samples.data());
            for (std::size_t i = 0; i < samples.size(); ++i) {
                dst[2 * i] = static_cast<std::uint8_t>(samples[i] >> 8);
                dst[2 * i + 1] = static_cast<std::uint8_t>(samples[i] & 0xFF);
            }
        };
    }
    std::vector<std::byte> bytes = image::encodePng(rows, png);
    report.encodeSeconds = seconds(t0);
    report.mapBytes = bytes.size();

    // Everything is staged in temporaries first, then renamed together, so an
    // error leaves no partial set of outputs.
    t0 = std::chrono::steady_clock::now();
    AtomicFile mapFile(out.map);
    mapFile.write(bytes);
    bytes = {};
    std::optional<AtomicFile> heightFile;
    if (out.height) {
        if (hf == HeightFormat::Exr) {
            image::writeExr(*out.height, H);
        } else {
            // 16-bit height: [min, max] -> [0, 65535]; the range is in the sidecar.
            image::Image16 h16(H.width(), H.height(), 1);
            const double lo = report.heightMin, range = std::max(1e-30, double(report.heightMax) - lo);
            for (std::size_t i = 0; i < H.size(); ++i)
                h16.data()[i] = static_cast<std::uint16_t>(std::floor((H.data()[i] - lo) / range * 65535.0 + 0.5));
            heightFile.emplace(*out.height);
            heightFile->write(image::encodePng(h16, png));
        }
    }
    std::optional<AtomicFile> sideFile;
    if (out.sidecar) {
        report.sidecar = sidecarPath(out.map);
        json s{{"generator", "mucosa map"},
               {"mucosa_version", std::string(version())},
               {"params", toJson(p)},
               {"outputs", json{{"map", out.map.filename().string()}}},
               {"height_range", json::array({report.heightMin, report.heightMax})},
               {"conventions",
                {{"encoding", "rgb = 0.5 * N + 0.5, N = (-Hu, -Hv, 1) / |(-Hu, -Hv, 1)|"},
                 {"u", "+u = left to right along a row"},
                 {"v", "+v = toward the first (top) row of the file: OpenGL / glTF 'green up'"},
                 {"strength", "Hu = strength * dH/du with u in map widths"}}}};
        if (out.height) s["outputs"]["height"] = out.height->filename().string();
        // Height and sidecar must sit next to the map for --from to find them.
        if (out.height && fs::absolute(*out.height).parent_path() != fs::absolute(out.map).parent_path())
            s["outputs"]["height"] = fs::absolute(*out.height).string();
        sideFile.emplace(report.sidecar);
        sideFile->write(s.dump(2) + "\n");
    }
    mapFile.commit();
    if (heightFile) heightFile->commit();
    if (sideFile) sideFile->commit();
    report.writeSeconds = seconds(t0);
    return report;
}

}  // namespace mucosa::reflectance
