#include <mucosa/reflectance/map.hpp>

#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/reflectance/normal_map.hpp>

#include "test_support.hpp"

using namespace mucosa;
using namespace mucosa::reflectance;

namespace {
double meanTiltDegrees(const image::Image8& m) {
    double s = 0;
    for (int y = 0; y < m.height(); ++y)
        for (int x = 0; x < m.width(); ++x) {
            const auto N = decode8(m.at(x, y, 0), m.at(x, y, 1), m.at(x, y, 2));
            s += std::acos(std::min(1.0, N[2])) * 180.0 / M_PI;
        }
    return s / (static_cast<double>(m.width()) * m.height());
}
// The registry: every parameter is set from JSON and from text through one
// path, and what is set is what the map, the sidecar and get() see.
TEST(MapRegistry, EveryParameterRoundTripsThroughJsonTextAndTheSidecar) {
    const nlohmann::json values = {{"size", 96},      {"frequency", 12.0},     {"octaves", 3},
                                   {"lacunarity", 3.0}, {"gain", 0.25},        {"seed", 18446744073709551615ull},
                                   {"z", 0.75},        {"strength", 0.02},     {"turbulence", true},
                                   {"tileable", true}, {"bits", 16}};
    ASSERT_EQ(reflectance::mapRegistry().size(), static_cast<std::size_t>(reflectance::kMapParamCount));
    MapParams fromJson, fromText;
    for (const reflectance::MapParamInfo& i : reflectance::mapRegistry()) {
        EXPECT_EQ(reflectance::findMapParam(i.name), &i);
        EXPECT_EQ(&reflectance::info(i.id), &i);
        const nlohmann::json& v = values.at(std::string(i.name));
        reflectance::set(fromJson, i.id, v, std::string(i.name));
        reflectance::setFromText(fromText, i.id, v.dump(), std::string(i.name));
    }
    EXPECT_EQ(fromJson.noise.seed, 18446744073709551615ull);  // whole, not through a double
    EXPECT_EQ(fromText.noise.seed, 18446744073709551615ull);
    for (const reflectance::MapParamInfo& i : reflectance::mapRegistry()) {
        const double want = values.at(std::string(i.name)).is_boolean()
                                ? (values.at(std::string(i.name)).get<bool>() ? 1.0 : 0.0)
                                : values.at(std::string(i.name)).get<double>();
        EXPECT_EQ(reflectance::get(fromJson, i.id), want) << i.name;
        EXPECT_EQ(reflectance::get(fromText, i.id), want) << i.name;
    }
    const MapParams back = mapParamsFromJson(toJson(fromJson), "x.json");
    for (const reflectance::MapParamInfo& i : reflectance::mapRegistry())
        EXPECT_EQ(reflectance::get(back, i.id), reflectance::get(fromJson, i.id)) << i.name;
}

// Out of range, fractional, wrapped or mistyped values are refused with the
// subject the caller named, never truncated.
TEST(MapRegistry, RefusesWhatDoesNotFitWithoutWrapping) {
    auto why = [](reflectance::MapParam id, std::string_view text) {
        MapParams p;
        try {
            reflectance::setFromText(p, id, text, "--x");
        } catch (const InputError& e) {
            EXPECT_EQ(e.subject(), "--x");
            return e.reason();
        }
        return std::string("accepted");
    };
    using reflectance::MapParam;
    EXPECT_EQ(why(MapParam::Seed, "-1"), "must be a whole number in 0..2^64-1, got -1");
    EXPECT_EQ(why(MapParam::Octaves, "33"), "must be in 1..32, got 33");
    EXPECT_EQ(why(MapParam::Octaves, "4294967299"), "must be in 1..32, got 4294967299");
    EXPECT_EQ(why(MapParam::Octaves, "3.5"), "must be a whole number, not 3.5");
    EXPECT_EQ(why(MapParam::Frequency, "0"), "must be a positive number, got 0");
    EXPECT_EQ(why(MapParam::Frequency, "1e999"), "'1e999' is not a number");
    EXPECT_EQ(why(MapParam::Strength, "lots"), "'lots' is not a number");
    EXPECT_EQ(why(MapParam::Tileable, "3"), "must be true or false, not number");
    EXPECT_EQ(why(MapParam::Size, "2097152"), "must be in 1..1048576, got 2097152");
    EXPECT_EQ(why(MapParam::Octaves, "32"), "accepted");
}

TEST(MapRegistry, ASidecarWithAnUnknownKeyIsRefusedNamingIt) {
    try {
        mapParamsFromJson(nlohmann::json{{"frequency", 8}, {"frequncy", 9}}, "m.json");
        FAIL();
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "field 'frequncy'");
        EXPECT_NE(e.reason().find("is not a map parameter (known: preset, size, frequency"), std::string::npos);
    }
}

}  // namespace

TEST(Map, SidecarRegeneratesTheSameBytes) {
    test::TempDir dir;
    MapParams p = findPreset("rough").params;
    p.size = 300;
    p.noise.seed = 12345;
    p.bits = 16;
    MapOutputs out;
    out.map = dir / "a.png";
    out.height = dir / "a_height.exr";
    const MapReport r = generateMap(p, out, 2);
    EXPECT_EQ(r.sidecar, dir / "a.json");
    const Sidecar s = readSidecar(r.sidecar);
    EXPECT_EQ(s.map, dir / "a.png");
    ASSERT_TRUE(s.height.has_value());
    EXPECT_EQ(toJson(s.params), toJson(p));
    const nlohmann::json j = nlohmann::json::parse(readTextFile(r.sidecar));
    EXPECT_FALSE(j["mucosa_version"].get<std::string>().empty());

    MapOutputs again;
    again.map = dir / "b.png";
    again.height = dir / "b_height.exr";
    generateMap(s.params, again, 1);  // another thread count, same bytes
    EXPECT_EQ(test::readBytes(dir / "a.png"), test::readBytes(dir / "b.png"));
    EXPECT_EQ(image::readExr(dir / "a_height.exr"), image::readExr(dir / "b_height.exr"));
}

// generateMap streams normals into the PNG encoder band by band; the file
// must hold exactly what encodeNormals8/16 compute for the whole height field
// (sizes spanning several encoder pieces, both depths, both edge modes).
TEST(Map, StreamedMapIsTheEncodedNormalsOfTheHeightField) {
    test::TempDir dir;
    for (int bits : {8, 16}) {
        for (bool tileable : {false, true}) {
            MapParams p = findPreset("bronchial").params;
            p.size = bits == 8 ? 700 : 520;
            p.bits = bits;
            p.noise.tileable = tileable;
            MapOutputs out;
            out.map = dir / "s.png";
            out.sidecar = false;
            generateMap(p, out, 2);
            const image::ImageF H = heightField(p, 2);
            const Edges edges = tileable ? Edges::Wrap : Edges::Clamp;
            const image::PngImage png = image::readPng(out.map);
            ASSERT_EQ(png.bitDepth, bits);
            if (bits == 8) {
                const image::Image8 ref = encodeNormals8(H, p.strength, edges, 1);
                EXPECT_EQ(image::to8(png), ref) << tileable;
            } else {
                EXPECT_EQ(png.pixels, encodeNormals16(H, p.strength, edges, 1)) << tileable;
            }
        }
    }
}

TEST(Map, HeightOutputMatchesTheHeightField) {
    test::TempDir dir;
    MapParams p;
    p.size = 64;
    MapOutputs out;
    out.map = dir / "m.png";
    out.height = dir / "h.png";
    const MapReport r = generateMap(p, out);
    const image::ImageF H = heightField(p);
    const image::PngImage h16 = image::readPng(dir / "h.png");
    ASSERT_EQ(h16.bitDepth, 16);
    const double range = r.heightMax - r.heightMin;
    for (int i = 0; i < 64 * 64; ++i) {
        const double back = r.heightMin + h16.pixels.data()[i] / 65535.0 * range;
        ASSERT_NEAR(back, H.data()[i], range / 65535.0);
    }
}

TEST(Map, PresetsAreValidAndDiffer) {
    ASSERT_GE(presets().size(), 3u);
    double previousTilt = -1;
    for (const char* name : {"serosa", "bronchial", "rough"}) {
        MapParams p = findPreset(name).params;
        EXPECT_NO_THROW(validate(p));
        p.size = 256;
        const image::Image8 m = encodeNormals8(heightField(p), p.strength, Edges::Wrap);
        const double tilt = meanTiltDegrees(m);
        EXPECT_GT(tilt, previousTilt) << name << ": presets go from smooth to rough";
        previousTilt = tilt;
    }
    EXPECT_THROW(findPreset("liver"), InputError);
}

TEST(Map, RefusesMapsThatWouldNotFitInMemoryBeforeAllocating) {
    test::TempDir dir;
    MapParams p;
    p.size = 1 << 20;  // 1M x 1M: terabytes
    MapOutputs out;
    out.map = dir / "huge.png";
    try {
        generateMap(p, out);
        FAIL() << "expected a ResourceError";
    } catch (const ResourceError& e) {
        EXPECT_NE(std::string(e.what()).find("bytes"), std::string::npos);
    }
    EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(Map, WarnsWhenOctavesAreFinerThanTheMapResolves) {
    test::TempDir dir;
    MapParams p;
    p.size = 64;
    p.noise.frequency = 8;
    p.noise.octaves = 6;  // 8..256 cycles; only 8, 16, 32 fit 64 texels
    MapOutputs out;
    out.map = dir / "m.png";
    const MapReport r = generateMap(p, out);
    EXPECT_EQ(r.resolvableOctaves, 3);
    ASSERT_EQ(r.warnings.size(), 1u);
    EXPECT_NE(r.warnings[0].find("only 3 of 6"), std::string::npos) << r.warnings[0];
}

TEST(Map, RejectsBadParametersNamingTheField) {
    MapParams p;
    p.size = 0;
    try {
        validate(p);
        FAIL();
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "size");
    }
    p = MapParams{};
    p.bits = 12;
    EXPECT_THROW(validate(p), InputError);
    p = MapParams{};
    p.strength = -1;
    EXPECT_THROW(validate(p), InputError);
    EXPECT_THROW(mapParamsFromJson(nlohmann::json{{"size", "big"}}, "x.json"), InputError);
    try {
        mapParamsFromJson(nlohmann::json{{"frequency", -2.0}}, "x.json");
        FAIL();
    } catch (const InputError& e) {
        EXPECT_STREQ(e.what(), "field 'frequency' in x.json: must be a positive number, got -2");
    }
}
