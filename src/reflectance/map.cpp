#include <mucosa/reflectance/map.hpp>

#include <algorithm>
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

double seconds(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

}  // namespace

void validate(const MapParams& p) {
    if (p.size < 1) throw InputError("size", "", fmt::format("must be at least 1, got {}", p.size));
    if (p.size > kMaxSize)
        throw InputError("size", "", fmt::format("{} exceeds the limit of {} texels", p.size, kMaxSize));
    if (!std::isfinite(p.strength) || p.strength < 0)
        throw InputError("strength", "", fmt::format("must be a number >= 0, got {}", p.strength));
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
    auto number = [&](const char* key, double& out) {
        if (!j.contains(key)) return;
        if (!j[key].is_number()) throw InputError(std::string("field '") + key + "'", file, "must be a number");
        out = j[key].get<double>();
    };
    auto integer = [&](const char* key, auto& out) {
        if (!j.contains(key)) return;
        out = detail::wholeNumber<std::remove_reference_t<decltype(out)>>(j[key], key, file);
    };
    auto boolean = [&](const char* key, bool& out) {
        if (!j.contains(key)) return;
        if (!j[key].is_boolean()) throw InputError(std::string("field '") + key + "'", file, "must be true or false");
        out = j[key].get<bool>();
    };
    integer("size", p.size);
    number("frequency", p.noise.frequency);
    integer("octaves", p.noise.octaves);
    number("lacunarity", p.noise.lacunarity);
    number("gain", p.noise.gain);
    integer("seed", p.noise.seed);
    number("z", p.noise.z);
    boolean("turbulence", p.noise.turbulence);
    boolean("tileable", p.noise.tileable);
    number("strength", p.strength);
    integer("bits", p.bits);
    if (j.contains("preset")) {
        if (!j["preset"].is_string()) throw InputError("field 'preset'", file, "must be a string");
        p.preset = j["preset"].get<std::string>();
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
