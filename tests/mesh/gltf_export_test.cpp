// glTF 2.0 with Mucosa's look (mucosa export, mesh --material, phantom) and
// re-export that keeps a model's own look: every file the CLI writes here is
// checked by the Khronos glTF-Validator (0 errors, 0 warnings, no UNUSED_*).
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/gltf.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/mesh/uv.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/scene/gltf_export.hpp>
#include <mucosa/scene/scene.hpp>
#include <mucosa/shading/gltf_material.hpp>

#include "gltf_validator.hpp"
#include "mesh_test_util.hpp"

namespace mucosa::test {
namespace {

using json = nlohmann::json;

std::string q(const std::filesystem::path& p) {
    return "'" + p.string() + "'";
}

// The bytes of image i of a parsed .glb.
std::string imageBytes(const Glb& g, int i) {
    const json& view = g.json["bufferViews"][g.json["images"][i]["bufferView"].get<int>()];
    return g.bin.substr(view.value("byteOffset", 0u), view["byteLength"].get<std::size_t>());
}

image::Image8 decode(const std::string& png) {
    std::vector<std::byte> b(png.size());
    std::memcpy(b.data(), png.data(), png.size());
    return image::to8(image::decodePng(b));
}

// The texel glTF samples for texture coordinate (s, t) through a
// KHR_texture_transform (offset, scale; rotation 0), repeat wrapping, as a
// fraction of the image (x from the left, y from the top).
std::array<double, 2> gltfTexel(const json& transform, double s, double t) {
    const double ox = transform.contains("offset") ? transform["offset"][0].get<double>() : 0;
    const double oy = transform.contains("offset") ? transform["offset"][1].get<double>() : 0;
    const double sx = transform.contains("scale") ? transform["scale"][0].get<double>() : 1;
    const double sy = transform.contains("scale") ? transform["scale"][1].get<double>() : 1;
    const double x = ox + sx * s, y = oy + sy * t;
    return {x - std::floor(x), y - std::floor(y)};
}

// The texel Mucosa's renderer samples for OpenGL texture coordinate (u, v)
// scaled and offset by (sx, sy, ox, oy): u' = u sx + ox, v' = v sy + oy; the
// file's first row is v' = 1 (repeat).
std::array<double, 2> mucosaTexel(double u, double v, double sx, double sy, double ox, double oy) {
    const double x = u * sx + ox, y = 1.0 - (v * sy + oy);
    return {x - std::floor(x), y - std::floor(y)};
}

double wrappedDistance(double a, double b) {
    const double d = std::abs(a - b);
    return std::min(d, 1.0 - d);
}

TEST(GltfMaterial, TextureTransformSamplesTheTexelsTheRendererSamples) {
    // The map's tiling and a fit atlas's rectangle, with glTF's v flip.
    for (const std::array<float, 4> gl : std::vector<std::array<float, 4>>{
             {4, 4, 0, 0}, {3.5f, 3.5f, 0, 0}, {0.37f, 0.37f, 0, 0}, {1.0f / 3, 1.0f / 1.5f, -2.0f / 3, 0.5f / 1.5f}}) {
        const shading::GltfTextureTransform t = shading::gltfTextureTransform(gl);
        json tj = {{"offset", {t.offset[0], t.offset[1]}}, {"scale", {t.scale[0], t.scale[1]}}};
        for (double u : {0.0, 0.13, 0.5, 0.77, 2.31})
            for (double v : {0.0, 0.21, 0.5, 0.93, -0.4}) {
                const auto a = gltfTexel(tj, u, 1.0 - v);  // the writer flips v
                const auto b = mucosaTexel(u, v, gl[0], gl[1], gl[2], gl[3]);
                EXPECT_LT(wrappedDistance(a[0], b[0]), 1e-5) << gl[0] << " " << u << "," << v;
                EXPECT_LT(wrappedDistance(a[1], b[1]), 1e-5) << gl[1] << " " << u << "," << v;
            }
    }
}

TEST(GltfMaterial, RegistryMappingFollowsTheDocumentedFormulas) {
    shading::ParamSet p;
    const shading::GltfMaterialValues d = shading::gltfMaterialValues(p);
    // Defaults: shininess 120, k_s 2, sheen 0.6 at exponent 8, IOR 1.34.
    EXPECT_NEAR(d.clearcoatRoughness, std::pow(2.0 / 482.0, 0.25), 1e-6);
    EXPECT_NEAR(d.clearcoatFactor, 2.0 * 4.0 * (2.0 / 482.0) / 0.04, 1e-5);  // 0.830
    EXPECT_NEAR(d.clearcoatFactor, 0.830, 0.001);
    EXPECT_NEAR(d.roughness, std::pow(2.0 / 34.0, 0.25), 1e-6);
    EXPECT_FLOAT_EQ(d.ior, 1.34f);
    EXPECT_FLOAT_EQ(d.specularFactor, 0.6f);
    EXPECT_FLOAT_EQ(d.clearcoatNormalScale, 1.0f);
    EXPECT_FLOAT_EQ(d.mapTiling, 4.0f);
    EXPECT_FALSE(d.clearcoatClamped);
    // Albedo without a texture: mix(base, mucus, 0.15).
    EXPECT_NEAR(d.albedoNoTexture[0], 0.75 * 0.85 + 0.95 * 0.15, 1e-6);
    // A tighter lobe is smoother; more k_s than a full coat is capped.
    p.set(shading::Param::Shininess, 1000);
    p.set(shading::Param::SpecularStrength, 32);
    const shading::GltfMaterialValues t = shading::gltfMaterialValues(p);
    EXPECT_LT(t.clearcoatRoughness, d.clearcoatRoughness);
    EXPECT_FLOAT_EQ(t.clearcoatFactor, 1.0f);
    EXPECT_TRUE(t.clearcoatClamped);
    // The GGX lobe's peak F0 / (4 alpha^2) equals k_s where not capped.
    p.set(shading::Param::SpecularStrength, 0.5f);
    const shading::GltfMaterialValues h = shading::gltfMaterialValues(p);
    const double alpha = double(h.clearcoatRoughness) * h.clearcoatRoughness;
    EXPECT_NEAR(h.clearcoatFactor * 0.04 / (4 * alpha * alpha), 0.5, 1e-4);
}

// Checks Mucosa's material in a written .glb against the parameters.
void expectMucosaMaterial(const Glb& g, const shading::ParamSet& p) {
    const shading::GltfMaterialValues v = shading::gltfMaterialValues(p);
    ASSERT_EQ(g.json["materials"].size(), 1u);
    const json& m = g.json["materials"][0];
    const json& coat = m["extensions"]["KHR_materials_clearcoat"];
    EXPECT_NEAR(coat["clearcoatFactor"].get<double>(), v.clearcoatFactor, 1e-6);
    EXPECT_NEAR(coat["clearcoatRoughnessFactor"].get<double>(), v.clearcoatRoughness, 1e-6);
    EXPECT_NEAR(m["extensions"]["KHR_materials_ior"]["ior"].get<double>(), v.ior, 1e-6);
    EXPECT_NEAR(m["extensions"]["KHR_materials_specular"]["specularFactor"].get<double>(), v.specularFactor, 1e-6);
    EXPECT_NEAR(m["pbrMetallicRoughness"]["roughnessFactor"].get<double>(), v.roughness, 1e-6);
    EXPECT_EQ(m["pbrMetallicRoughness"]["metallicFactor"].get<double>(), 0.0);
    // Every primitive has the material, and TANGENT (the coat's normal texture reads it).
    for (const json& prim : g.json["meshes"][0]["primitives"]) {
        EXPECT_EQ(prim["material"], 0);
        EXPECT_TRUE(prim["attributes"].contains("TANGENT"));
    }
    const std::vector<std::string> used = g.json["extensionsUsed"];
    for (const char* e : {"KHR_materials_clearcoat", "KHR_materials_ior", "KHR_materials_specular"})
        EXPECT_NE(std::find(used.begin(), used.end(), e), used.end()) << e;
    EXPECT_FALSE(g.json.contains("extensionsRequired"));
}

// The sRGB texel the renderer's albedo gives (independent of the library:
// mix(srgbToLinear(t) base, mucus, o), sRGB-encoded).
int bakedTexel(int t, double base, double mucus, double o) {
    const double s = t / 255.0;
    const double lin = s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
    const double a = std::clamp(lin * base * (1 - o) + mucus * o, 0.0, 1.0);
    const double e = a <= 0.0031308 ? 12.92 * a : 1.055 * std::pow(a, 1 / 2.4) - 0.055;
    return static_cast<int>(std::lround(e * 255));
}

TEST(GltfExport, PhantomCarriesTheWetLookAndValidates) {
    TempDir dir;
    const auto r = runCli("-q phantom -o " + q(dir / "a.glb") + " --generations 1 --resolution 1");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    expectValidGltf(dir / "a.glb");
    const Glb g = parseGlb(readBytes(dir / "a.glb"));
    const shading::ParamSet p = scene::defaultScene().params;  // the default look's material
    expectMucosaMaterial(g, p);
    const json& m = g.json["materials"][0];
    EXPECT_EQ(m["doubleSided"], true);  // an airway, seen from inside
    // The textures: the default look's, the map exactly the generated one.
    scene::Scene s = scene::defaultScene();
    scene::SceneAssets assets;
    scene::loadTextures(s, assets);
    const json& coat = m["extensions"]["KHR_materials_clearcoat"];
    const int mapImage = g.json["textures"][coat["clearcoatNormalTexture"]["index"].get<int>()]["source"];
    const image::Image8 map = decode(imageBytes(g, mapImage));
    ASSERT_EQ(map.width(), assets.reflectanceMap.width());
    ASSERT_EQ(map.channels(), assets.reflectanceMap.channels());
    EXPECT_TRUE(std::equal(map.data(), map.data() + map.size(), assets.reflectanceMap.data()));
    // The map tiling: 4 repeats, offset 1 - 4 = -3 = 0 (mod 1).
    const json& tt = coat["clearcoatNormalTexture"]["extensions"]["KHR_texture_transform"];
    EXPECT_EQ(tt["scale"], json::array({4.0, 4.0}));
    EXPECT_FALSE(tt.contains("offset"));
    // The base colour: the generated texture with the mucus layer baked in.
    const int baseImage =
        g.json["textures"][m["pbrMetallicRoughness"]["baseColorTexture"]["index"].get<int>()]["source"];
    const image::Image8 base = decode(imageBytes(g, baseImage));
    ASSERT_EQ(base.width(), assets.diffuse.width());
    ASSERT_EQ(base.channels(), 3);
    const auto& bc = p.color(shading::Param::BaseColor);
    const auto& mc = p.color(shading::Param::MucusColor);
    const double o = p[shading::Param::MucusOpacity];
    int worst = 0;
    for (int y = 0; y < base.height(); y += 7)
        for (int x = 0; x < base.width(); x += 5)
            for (int k = 0; k < 3; ++k)
                worst = std::max(worst, std::abs(int(base.at(x, y, k)) -
                                                 bakedTexel(assets.diffuse.at(x, y, k),
                                                            s.params.color(shading::Param::BaseColor)[k], mc[k], o)));
    EXPECT_LE(worst, 1);
    (void)bc;
    // The geometry: metres, and the mesh reads back as the phantom.
    const Mesh back = mesh::load(dir / "a.glb");
    EXPECT_TRUE(back.hasUvs());
    EXPECT_TRUE(back.hasTangents());
}

// A scene with its own map file, diffuse file and material values.
struct SceneFiles {
    std::filesystem::path scene, map, diffuse;
};

SceneFiles writeScene(const TempDir& dir, const std::string& material) {
    SceneFiles f{dir / "scene.json", dir / "map.png", dir / "skin.png"};
    // A small real map (a mucosa map output would do as well) and a texture.
    reflectance::MapParams mp = reflectance::findPreset("bronchial").params;
    mp.size = 64;
    const image::ImageF h = reflectance::heightField(mp, 1);
    image::writePng(f.map, reflectance::encodeNormals8(h, mp.strength, reflectance::Edges::Wrap, 1));
    image::Image8 skin(32, 16, 3);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 32; ++x) {
            skin.at(x, y, 0) = static_cast<std::uint8_t>(8 * x);
            skin.at(x, y, 1) = static_cast<std::uint8_t>(16 * y);
            skin.at(x, y, 2) = 200;
        }
    image::writePng(f.diffuse, skin);
    std::ofstream(f.scene) << R"({"mesh": "tube", "diffuse": "skin.png", "reflectance_map": "map.png", "material": )"
                           << material << "}";
    return f;
}

TEST(GltfExport, SceneRoundTripsThroughGlbAndGltf) {
    TempDir dir;
    const SceneFiles f =
        writeScene(dir, R"({"shininess": 200, "specular_strength": 1, "bump_scale": 1.5, "map_tiling": 3.5})");
    for (const char* name : {"tube.glb", "tube.gltf"}) {
        const auto r = runCli("-q export " + q(f.scene) + " -o " + q(dir / name));
        ASSERT_EQ(r.exitCode, 0) << name << ": " << r.err;
        expectValidGltf(dir / name);
    }
    const Glb g = parseGlb(readBytes(dir / "tube.glb"));
    shading::ParamSet p;
    p.set(shading::Param::Shininess, 200);
    p.set(shading::Param::SpecularStrength, 1);
    p.set(shading::Param::BumpScale, 1.5f);
    p.set(shading::Param::MapTiling, 3.5f);
    expectMucosaMaterial(g, p);
    const json& coat = g.json["materials"][0]["extensions"]["KHR_materials_clearcoat"];
    EXPECT_NEAR(coat["clearcoatRoughnessFactor"].get<double>(), std::pow(2.0 / 802.0, 0.25), 1e-6);
    EXPECT_NEAR(coat["clearcoatNormalTexture"]["scale"].get<double>(), 1.5, 1e-6);
    // The clearcoat normal texture is the map file, byte for byte.
    const int mapImage = g.json["textures"][coat["clearcoatNormalTexture"]["index"].get<int>()]["source"];
    EXPECT_EQ(imageBytes(g, mapImage), readBytes(f.map));
    EXPECT_EQ(g.json["images"][mapImage]["mimeType"], "image/png");
    // Tiling 3.5: scale 3.5, offset (0, 1 - 3.5 mod 1 = 0.5).
    const json& tt = coat["clearcoatNormalTexture"]["extensions"]["KHR_texture_transform"];
    EXPECT_EQ(tt["scale"], json::array({3.5, 3.5}));
    EXPECT_EQ(tt["offset"], json::array({0.0, 0.5}));
    // The tube is open: double-sided.
    EXPECT_EQ(g.json["materials"][0]["doubleSided"], true);
    // The .gltf carries the same JSON, its images as data URIs.
    const json t = json::parse(readBytes(dir / "tube.gltf"));
    EXPECT_EQ(t["materials"], g.json["materials"]);
    EXPECT_EQ(t["textures"], g.json["textures"]);
    for (const json& im : t["images"]) EXPECT_EQ(im["uri"].get<std::string>().rfind("data:image/png;base64,", 0), 0u);
    // Both read back (through Assimp) as the same mesh.
    const Mesh a = mesh::load(dir / "tube.glb"), b = mesh::load(dir / "tube.gltf");
    EXPECT_EQ(a.positions, b.positions);
    EXPECT_EQ(a.uvs, b.uvs);
}

TEST(GltfExport, FittedAtlasKeepsItsBytesAndUvRectangle) {
    TempDir dir;
    std::filesystem::create_directories(dir / "fit");
    image::Image8 atlas(16, 8, 3);
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 16; ++x) atlas.at(x, y, 0) = atlas.at(x, y, 1) = atlas.at(x, y, 2) = std::uint8_t(x * 16);
    image::writePng(dir / "fit/texture.png", atlas);
    std::ofstream(dir / "fit/brdf.json")
        << R"({"c": [0, 1, 0, 0], "d": [0, 0, 0], "zmin": 0, "zmax": 100, "uv_min": [2, -0.5], "uv_max": [5, 1]})";
    std::ofstream(dir / "scene.json") << R"({"mesh": "tube", "fit": "fit", "mode": "brdf-noise"})";
    const auto r = runCli("-q export " + q(dir / "scene.json") + " -o " + q(dir / "f.glb"));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    expectValidGltf(dir / "f.glb");
    const Glb g = parseGlb(readBytes(dir / "f.glb"));
    const json& info = g.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"];
    EXPECT_EQ(imageBytes(g, g.json["textures"][info["index"].get<int>()]["source"]),
              readBytes(dir / "fit/texture.png"));
    // uv_min..uv_max maps to the whole atlas: (2, -0.5) is its bottom-left
    // corner, (5, 1) its top-right, in Mucosa's (OpenGL) coordinates.
    const json& tt = info["extensions"]["KHR_texture_transform"];
    const auto bl = gltfTexel(tt, 2.0, 1.0 - (-0.5)), tr = gltfTexel(tt, 5.0 - 1e-6, 1.0 - (1.0 - 1e-6));
    EXPECT_LT(wrappedDistance(bl[0], 0.0), 1e-5);  // the first column
    EXPECT_LT(wrappedDistance(bl[1], 1.0), 1e-5);  // the last row
    EXPECT_NEAR(tr[0], 1.0, 1e-5);                 // the last column
    EXPECT_NEAR(tr[1], 0.0, 1e-5);                 // the first row
}

TEST(GltfExport, BadInputsGiveOneErrorLineAndWriteNothing) {
    TempDir dir;
    std::ofstream(dir / "missing_texture.json") << R"({"mesh": "tube", "diffuse": "nope.png"})";
    std::ofstream(dir / "broken.json") << R"({"mesh": "tube", "material": {"shininess": })";
    std::ofstream(dir / "range.json") << R"({"mesh": "tube", "material": {"shininess": 1e9}})";
    const std::filesystem::path out = dir / "out.glb";
    for (const char* s : {"missing_texture.json", "broken.json", "range.json", "absent.json"}) {
        const auto r = runCli("export " + q(dir / s) + " -o " + q(out));
        EXPECT_NE(r.exitCode, 0) << s;
        expectOneErrorLine(r.err, s);
        EXPECT_FALSE(std::filesystem::exists(out)) << s;
    }
    const auto unwritable = runCli("export -o " + q(dir / "no" / "dir" / "x.glb"));
    EXPECT_NE(unwritable.exitCode, 0);
    expectOneErrorLine(unwritable.err, "unwritable");
    const auto ply = runCli("export -o " + q(dir / "x.ply"));
    EXPECT_NE(ply.exitCode, 0);
    expectOneErrorLine(ply.err, "ply");
    EXPECT_FALSE(std::filesystem::exists(dir / "x.ply"));
    // mesh: Mucosa's material needs glTF output, and UVs.
    const std::filesystem::path in = testdata("gltf/NormalTangentTest.glb");
    const auto m1 = runCli("mesh " + q(in) + " -o " + q(dir / "x.obj") + " --material mucosa");
    EXPECT_NE(m1.exitCode, 0);
    expectOneErrorLine(m1.err, "obj material");
    std::ofstream(dir / "tri.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    const auto m2 = runCli("mesh " + q(dir / "tri.obj") + " -o " + q(out) + " --material mucosa");
    EXPECT_NE(m2.exitCode, 0);
    expectOneErrorLine(m2.err, "no uvs");
    const auto m3 = runCli("mesh " + q(in) + " -o " + q(out) + " --material shiny");
    EXPECT_NE(m3.exitCode, 0);
    expectOneErrorLine(m3.err, "unknown material");
    const auto m4 = runCli("mesh " + q(in) + " -o " + q(out) + " --look " + q(dir / "broken.json"));
    EXPECT_NE(m4.exitCode, 0);
    expectOneErrorLine(m4.err, "broken look");
    // phantom: a look is a glTF material; an OBJ has none to carry it.
    std::ofstream(dir / "look.json") << R"({"mesh": "tube"})";
    const auto p1 = runCli("phantom -o " + q(dir / "p.obj") + " --look " + q(dir / "look.json"));
    EXPECT_NE(p1.exitCode, 0);
    expectOneErrorLine(p1.err, "look .glb");
    EXPECT_FALSE(std::filesystem::exists(dir / "p.obj"));
    EXPECT_FALSE(std::filesystem::exists(out));
}

// A small glTF with its own look: two primitives (x < 0 and x > 0) with two
// materials, one textured through the file's UVs with a sampler, one with
// KHR_materials_emissive_strength, and a third without a material (z = 5).
struct OwnModel {
    json doc;
    std::string bin;
    std::string png;
};

OwnModel ownModel() {
    OwnModel o;
    image::Image8 tex(4, 4, 3);
    for (int i = 0; i < 4 * 4 * 3; ++i) tex.data()[i] = static_cast<std::uint8_t>(i * 5);
    const std::vector<std::byte> png = image::encodePng(tex);
    o.png.assign(reinterpret_cast<const char*>(png.data()), png.size());
    std::vector<float> pos, uv;
    std::vector<std::uint16_t> idx;
    auto quad = [&](float x0, float z) {
        const auto base = static_cast<std::uint16_t>(pos.size() / 3);
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i) {
                pos.insert(pos.end(), {(x0 + float(i)) * 0.01f, float(j) * 0.01f, z * 0.01f});
                uv.insert(uv.end(), {float(i), float(1 - j)});
            }
        idx.insert(idx.end(), {base, std::uint16_t(base + 1), std::uint16_t(base + 3), base, std::uint16_t(base + 3),
                               std::uint16_t(base + 2)});
    };
    quad(-2, 0);
    quad(1, 0);
    quad(-0.5f, 5);
    auto append = [&](const void* d, std::size_t n) {
        while (o.bin.size() % 4) o.bin.push_back('\0');
        const std::size_t at = o.bin.size();
        o.bin.append(static_cast<const char*>(d), n);
        return at;
    };
    const std::size_t pAt = append(pos.data(), pos.size() * 4), uAt = append(uv.data(), uv.size() * 4);
    const std::size_t iAt = append(idx.data(), idx.size() * 2), imgAt = append(o.png.data(), o.png.size());
    while (o.bin.size() % 4) o.bin.push_back('\0');
    json views = json::array({{{"buffer", 0}, {"byteOffset", pAt}, {"byteLength", pos.size() * 4}, {"target", 34962}},
                              {{"buffer", 0}, {"byteOffset", uAt}, {"byteLength", uv.size() * 4}, {"target", 34962}},
                              {{"buffer", 0}, {"byteOffset", iAt}, {"byteLength", idx.size() * 2}, {"target", 34963}},
                              {{"buffer", 0}, {"byteOffset", imgAt}, {"byteLength", o.png.size()}}});
    std::array<float, 3> lo{1e9f, 1e9f, 1e9f}, hi{-1e9f, -1e9f, -1e9f};
    for (std::size_t i = 0; i < pos.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], pos[i]);
        hi[i % 3] = std::max(hi[i % 3], pos[i]);
    }
    json accessors = json::array({{{"bufferView", 0},
                                   {"componentType", 5126},
                                   {"count", 12},
                                   {"type", "VEC3"},
                                   {"min", {lo[0], lo[1], lo[2]}},
                                   {"max", {hi[0], hi[1], hi[2]}}},
                                  {{"bufferView", 1}, {"componentType", 5126}, {"count", 12}, {"type", "VEC2"}}});
    for (int k = 0; k < 3; ++k)
        accessors.push_back(
            {{"bufferView", 2}, {"byteOffset", 12 * k}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}});
    json attrs = {{"POSITION", 0}, {"TEXCOORD_0", 1}};
    o.doc = {
        {"asset", {{"version", "2.0"}, {"generator", "mucosa test"}}},
        {"extensionsUsed", {"KHR_materials_emissive_strength"}},
        {"scene", 0},
        {"scenes", json::array({{{"nodes", {0}}}})},
        {"nodes", json::array({{{"mesh", 0}, {"name", "own"}}})},
        {"meshes", json::array({{{"primitives", json::array({{{"attributes", attrs}, {"indices", 2}, {"material", 0}},
                                                             {{"attributes", attrs}, {"indices", 3}, {"material", 1}},
                                                             {{"attributes", attrs}, {"indices", 4}}})}}})},
        {"materials",
         json::array({{{"name", "textured"},
                       {"pbrMetallicRoughness",
                        {{"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0.25}, {"roughnessFactor", 0.7}}},
                       {"alphaMode", "MASK"},
                       {"alphaCutoff", 0.3},
                       {"extras", {{"author", "a test"}}}},
                      {{"name", "glowing"},
                       {"emissiveFactor", {1.0, 0.5, 0.25}},
                       {"doubleSided", true},
                       {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 4.0}}}}}}})},
        {"textures", json::array({{{"sampler", 0}, {"source", 0}, {"name", "checker"}}})},
        {"samplers", json::array({{{"magFilter", 9728}, {"minFilter", 9728}, {"wrapS", 33071}, {"wrapT", 33648}}})},
        {"images", json::array({{{"bufferView", 3}, {"mimeType", "image/png"}, {"name", "checker image"}}})},
        {"accessors", accessors},
        {"bufferViews", views},
        {"buffers", json::array({{{"byteLength", o.bin.size()}}})}};
    return o;
}

void writeGlb(const std::filesystem::path& path, std::string j, const std::string& bin) {
    while (j.size() % 4) j += ' ';
    std::string out;
    auto u32 = [&](std::uint32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); };
    u32(0x46546C67);
    u32(2);
    u32(static_cast<std::uint32_t>(12 + 8 + j.size() + 8 + bin.size()));
    u32(static_cast<std::uint32_t>(j.size()));
    u32(0x4E4F534A);
    out += j;
    u32(static_cast<std::uint32_t>(bin.size()));
    u32(0x004E4942);
    out += bin;
    std::ofstream(path, std::ios::binary) << out;
}

TEST(GltfReexport, KeepsTheModelsOwnMaterialsTexturesAndExtensions) {
    TempDir dir;
    const OwnModel own = ownModel();
    writeGlb(dir / "own.glb", own.doc.dump(), own.bin);
    // The input is valid; the validator notes its TEXCOORD_0 as unused on the
    // two primitives whose material reads no texture. The output keeps the
    // UVs (the user's data) and adds no issue of its own: exactly those two.
    auto unusedOf = [](const json& report) {
        std::vector<std::string> u;
        for (const json& m : report["messages"])
            u.push_back(m["code"].get<std::string>() + " " + m["pointer"].get<std::string>());
        return u;
    };
    const json input = validateGltf(dir / "own.glb");
    EXPECT_EQ(input["errors"], 0) << input.dump();
    EXPECT_EQ(input["warnings"], 0) << input.dump();
    const std::vector<std::string> inputIssues = unusedOf(input);
    EXPECT_EQ(inputIssues, (std::vector<std::string>{"UNUSED_OBJECT /meshes/0/primitives/1/attributes/TEXCOORD_0",
                                                     "UNUSED_OBJECT /meshes/0/primitives/2/attributes/TEXCOORD_0"}));
    for (const char* args : {"", " --weld --flip", " --recompute-normals"})
        for (const char* name : {"out.glb", "out.gltf"}) {
            SCOPED_TRACE(std::string(name) + args);
            std::filesystem::remove(dir / name);
            const auto r = runCli("-q mesh " + q(dir / "own.glb") + " -o " + q(dir / name) + args);
            ASSERT_EQ(r.exitCode, 0) << r.err;
            const json report = validateGltf(dir / name);
            EXPECT_EQ(report["errors"], 0) << report.dump();
            EXPECT_EQ(report["warnings"], 0) << report.dump();
            EXPECT_EQ(unusedOf(report), inputIssues) << report.dump();
            json j;
            std::string png;
            if (std::string(name) == "out.glb") {
                const Glb g = parseGlb(readBytes(dir / name));
                j = g.json;
                png = imageBytes(g, 0);
            } else {
                j = json::parse(readBytes(dir / name));
                std::vector<std::uint8_t> d;
                const mesh::GltfLook look = mesh::readGltfLook(dir / name);
                png.assign(look.imageData[0].begin(), look.imageData[0].end());
            }
            // Materials, textures and samplers survive as they were, byte for byte.
            EXPECT_EQ(j["materials"].dump(), own.doc["materials"].dump());
            EXPECT_EQ(j["textures"].dump(), own.doc["textures"].dump());
            EXPECT_EQ(j["samplers"].dump(), own.doc["samplers"].dump());
            EXPECT_EQ(j["images"][0]["name"], "checker image");
            EXPECT_EQ(j["images"][0]["mimeType"], std::string(name) == "out.glb" ? json("image/png") : json());
            EXPECT_EQ(png, own.png);
            EXPECT_EQ(j["extensionsUsed"], json::array({"KHR_materials_emissive_strength"}));
            // Each primitive keeps its material: material 0 left of x = 0,
            // material 1 right, the third without one at z = 5 cm.
            const json& prims = j["meshes"][0]["primitives"];
            ASSERT_EQ(prims.size(), 3u);
            EXPECT_EQ(prims[0]["material"], 0);
            EXPECT_EQ(prims[1]["material"], 1);
            EXPECT_FALSE(prims[2].contains("material"));
            // No TANGENT: neither material reads a normal texture.
            for (const json& p : prims) EXPECT_FALSE(p["attributes"].contains("TANGENT"));
        }
    // Which triangles each primitive holds: by position, from the .glb.
    const Glb g = parseGlb(readBytes(dir / "out.glb"));
    const std::vector<float> P = accessorFloats(g, g.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"]);
    for (int k = 0; k < 3; ++k) {
        const json& prim = g.json["meshes"][0]["primitives"][k];
        const json& acc = g.json["accessors"][prim["indices"].get<int>()];
        EXPECT_EQ(acc["count"], 6);
        const json& view = g.json["bufferViews"][acc["bufferView"].get<int>()];
        for (int i = 0; i < 6; ++i) {
            std::uint16_t v;
            std::memcpy(&v, g.bin.data() + view.value("byteOffset", 0) + acc.value("byteOffset", 0) + 2 * i, 2);
            const float x = P[3 * v], z = P[3 * v + 2];
            if (k == 0) {
                EXPECT_LT(x, 0.0f);
            } else if (k == 1) {
                EXPECT_GT(x, 0.0f);
            } else {
                EXPECT_NEAR(z, 0.05f, 1e-6);
            }
        }
    }
}

TEST(GltfReexport, ReplacesTheLookOnlyWhenAskedAndRefusesWhatWouldBreakIt) {
    TempDir dir;
    const OwnModel own = ownModel();
    writeGlb(dir / "own.glb", own.doc.dump(), own.bin);
    // Centerline UVs would re-map the textured material: refused, nothing written.
    const auto cl = runCli("mesh " + q(dir / "own.glb") + " -o " + q(dir / "cl.glb") + " --uv centerline");
    EXPECT_NE(cl.exitCode, 0);
    expectOneErrorLine(cl.err, "centerline over a textured material");
    EXPECT_NE(cl.err.find("material 0"), std::string::npos) << cl.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "cl.glb"));
    // Asked for: Mucosa's look replaces theirs (one material, the coat).
    const auto mu = runCli("-q mesh " + q(dir / "own.glb") + " -o " + q(dir / "mu.glb") + " --material mucosa");
    ASSERT_EQ(mu.exitCode, 0) << mu.err;
    expectValidGltf(dir / "mu.glb");
    const Glb g = parseGlb(readBytes(dir / "mu.glb"));
    expectMucosaMaterial(g, scene::defaultScene().params);
    EXPECT_EQ(g.json["meshes"][0]["primitives"].size(), 1u);
    // Plain: one untextured material, no tangents, no images. The UVs the
    // user has are still written, with a warning: the one UNUSED_* info a
    // user can ask for (TEXCOORD_0 that no material reads).
    const auto pl = runCli("-q mesh " + q(dir / "own.glb") + " -o " + q(dir / "pl.gltf") + " --material plain");
    ASSERT_EQ(pl.exitCode, 0) << pl.err;
    EXPECT_NE(pl.err.find("warning: the plain material reads no texture"), std::string::npos) << pl.err;
    const json report = validateGltf(dir / "pl.gltf");
    EXPECT_EQ(report["errors"], 0);
    EXPECT_EQ(report["warnings"], 0);
    ASSERT_EQ(report["messages"].size(), 1u) << report.dump();
    EXPECT_EQ(report["messages"][0]["code"], "UNUSED_OBJECT");
    EXPECT_EQ(report["messages"][0]["pointer"], "/meshes/0/primitives/0/attributes/TEXCOORD_0");
    const json p = json::parse(readBytes(dir / "pl.gltf"));
    EXPECT_EQ(p["materials"].size(), 1u);
    EXPECT_FALSE(p.contains("images"));
    // Without UVs (an OBJ triangle), auto is plain and the file is clean.
    std::ofstream(dir / "tri.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    const auto tri = runCli("-q mesh " + q(dir / "tri.obj") + " -o " + q(dir / "tri.glb"));
    ASSERT_EQ(tri.exitCode, 0) << tri.err;
    expectValidGltf(dir / "tri.glb");
    const Glb t = parseGlb(readBytes(dir / "tri.glb"));
    EXPECT_EQ(t.json["materials"][0]["name"], "mucosa plain");
    EXPECT_EQ(t.json["materials"][0]["doubleSided"], true);  // open
    // An OBJ with UVs (the CT airway with centerline UVs): auto is Mucosa's look.
    const auto ct = runCli("-q mesh " + q(testdata("airway/vh_m_airway_lumen.obj")) + " -o " + q(dir / "ct.glb") +
                           " --uv centerline");
    ASSERT_EQ(ct.exitCode, 0) << ct.err;
    expectValidGltf(dir / "ct.glb");
    expectMucosaMaterial(parseGlb(readBytes(dir / "ct.glb")), scene::defaultScene().params);
    // keep needs a glTF input.
    const auto k = runCli("mesh " + q(dir / "tri.obj") + " -o " + q(dir / "k.glb") + " --material keep");
    EXPECT_NE(k.exitCode, 0);
    expectOneErrorLine(k.err, "keep obj");
    // A dangling texture index in the input is named, not written.
    OwnModel bad = own;
    bad.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = 7;
    writeGlb(dir / "bad.glb", bad.doc.dump(), bad.bin);
    const auto b = runCli("mesh " + q(dir / "bad.glb") + " -o " + q(dir / "b.glb"));
    EXPECT_NE(b.exitCode, 0);
    expectOneErrorLine(b.err, "dangling texture");
    EXPECT_FALSE(std::filesystem::exists(dir / "b.glb"));
}

TEST(GltfReexport, ReadsSideFilesBesideTheModelOnly) {
    TempDir dir;
    const OwnModel own = ownModel();
    // The same model as .gltf with its buffer and image as files beside it.
    json doc = own.doc;
    doc["buffers"][0]["uri"] = "own data.bin";
    doc["images"][0] = {{"uri", "tex%20ture.png"}, {"name", "checker image"}};
    std::ofstream(dir / "own data.bin", std::ios::binary) << own.bin;
    std::ofstream(dir / "tex ture.png", std::ios::binary) << own.png;
    std::ofstream(dir / "own.gltf") << doc.dump();
    const auto r = runCli("-q mesh " + q(dir / "own.gltf") + " -o " + q(dir / "out.glb"));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Glb g = parseGlb(readBytes(dir / "out.glb"));
    EXPECT_EQ(imageBytes(g, 0), own.png);
    EXPECT_EQ(g.json["images"][0]["mimeType"], "image/png");  // sniffed: a bufferView needs it
    EXPECT_EQ(g.json["materials"].dump(), own.doc["materials"].dump());
    // An image outside the model's folder is not read.
    std::filesystem::create_directories(dir / "sub");
    std::filesystem::copy_file(dir / "own data.bin", dir / "sub" / "own data.bin");
    doc["images"][0]["uri"] = "../tex%20ture.png";
    std::ofstream(dir / "sub" / "own.gltf") << doc.dump();
    const auto out = runCli("mesh " + q(dir / "sub" / "own.gltf") + " -o " + q(dir / "sub.glb"));
    EXPECT_NE(out.exitCode, 0);
    expectOneErrorLine(out.err, "outside");
    EXPECT_NE(out.err.find("model's folder"), std::string::npos) << out.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "sub.glb"));
    // Nesting deep enough to exhaust a recursive walk is refused up front.
    // (Spliced in as text: serialising it from a json would recurse too.)
    OwnModel deep = own;
    deep.doc["materials"][1]["extras"] = {{"deep", "NEST"}};
    std::string text = deep.doc.dump();
    text.replace(text.find("\"NEST\""), 6, std::string(100000, '[') + std::string(100000, ']'));
    writeGlb(dir / "deep.glb", text, deep.bin);
    const auto d = runCli("mesh " + q(dir / "deep.glb") + " -o " + q(dir / "deep_out.glb"));
    EXPECT_NE(d.exitCode, 0);
    expectOneErrorLine(d.err, "deep");
    EXPECT_FALSE(std::filesystem::exists(dir / "deep_out.glb"));
    // The reader itself refuses it (whatever the importer made of it).
    try {
        mesh::readGltfLook(dir / "deep.glb");
        ADD_FAILURE() << "deep nesting was read";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("nested deeper than 64 levels"), std::string::npos) << e.what();
    }
}

TEST(GltfReexport, SampleModelKeepsItsNormalMapAndTangents) {
    TempDir dir;
    const std::filesystem::path in = testdata("gltf/NormalTangentTest.glb");
    const mesh::GltfLook before = mesh::readGltfLook(in);
    const auto r = runCli("-q mesh " + q(in) + " -o " + q(dir / "o.glb"));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    expectValidGltf(dir / "o.glb");
    const Glb g = parseGlb(readBytes(dir / "o.glb"));
    EXPECT_EQ(g.json["materials"], before.materials);
    EXPECT_EQ(g.json["textures"], before.textures);
    ASSERT_EQ(g.json["images"].size(), before.images.size());
    for (std::size_t i = 0; i < before.images.size(); ++i) {
        const std::string b = imageBytes(g, static_cast<int>(i));
        EXPECT_EQ(b, std::string(before.imageData[i].begin(), before.imageData[i].end()));
    }
    for (const json& p : g.json["meshes"][0]["primitives"]) EXPECT_TRUE(p["attributes"].contains("TANGENT"));
}

TEST(GltfLook, TriangleMaterialsFollowRepairsAndUvSplits) {
    // Degenerate triangles dropped: the others keep their materials.
    Mesh m = grid(2);  // 8 triangles
    m.materials = {0, 1, 2, 3, 4, 5, 6, 7};
    m.indices[3 * 2 + 1] = m.indices[3 * 2];  // triangle 2 degenerate
    EXPECT_EQ(mesh::removeDegenerateTriangles(m), 1u);
    EXPECT_EQ(m.materials, (std::vector<std::uint32_t>{0, 1, 3, 4, 5, 6, 7}));
    // Welding merges vertices, never triangles.
    Mesh w = grid(2);
    w.materials = {7, 6, 5, 4, 3, 2, 1, 0};
    mesh::weld(w, 0.5f);
    EXPECT_EQ(w.materials, (std::vector<std::uint32_t>{7, 6, 5, 4, 3, 2, 1, 0}));
    // Centerline UVs split vertices at the seam; each triangle keeps its material.
    Mesh tube = mesh::makeTube(5, 40, 24, 20);
    for (std::size_t t = 0; t < tube.triangleCount(); ++t) tube.materials.push_back(t % 3 == 0 ? 1u : 0u);
    std::vector<Vec3> centroids;
    for (std::size_t t = 0; t < tube.triangleCount(); ++t) {
        Vec3 c{0, 0, 0};
        for (int k = 0; k < 3; ++k)
            for (int d = 0; d < 3; ++d) c[d] += tube.positions[tube.indices[3 * t + k]][d] / 3;
        centroids.push_back(c);
    }
    const std::vector<std::uint32_t> before = tube.materials;
    mesh::computeCenterlineUvs(tube);
    ASSERT_EQ(tube.materials, before);
    for (std::size_t t = 0; t < tube.triangleCount(); ++t) {
        Vec3 c{0, 0, 0};
        for (int k = 0; k < 3; ++k)
            for (int d = 0; d < 3; ++d) c[d] += tube.positions[tube.indices[3 * t + k]][d] / 3;
        ASSERT_NEAR(c[0], centroids[t][0], 1e-4) << t;  // the same triangle at the same index
        ASSERT_NEAR(c[1], centroids[t][1], 1e-4) << t;
    }
    // A mismatch is refused, not written.
    Mesh bad = grid(1);
    bad.materials = {0};
    EXPECT_THROW(mesh::validateIndices(bad), InputError);
}

TEST(GltfLook, PruningDropsUnreachableTexturesAndRenumbers) {
    mesh::GltfLook look;
    look.materials = json::array(
        {{{"name", "a"}, {"normalTexture", {{"index", 1}}}}, {{"name", "b"}, {"emissiveTexture", {{"index", 0}}}}});
    look.textures = json::array({{{"source", 0}, {"sampler", 0}}, {{"source", 1}, {"sampler", 1}}});
    look.samplers = json::array({{{"magFilter", 9728}}, {{"magFilter", 9729}}});
    look.images =
        json::array({{{"mimeType", "image/png"}, {"name", "i0"}}, {{"mimeType", "image/png"}, {"name", "i1"}}});
    look.imageData = {{1, 2}, {3, 4}};
    const auto map = mesh::pruneGltfLook(look, {true, false});
    EXPECT_EQ(map, (std::vector<std::uint32_t>{0, mesh::kNoMaterial}));
    ASSERT_EQ(look.materials.size(), 1u);
    EXPECT_EQ(look.materials[0]["normalTexture"]["index"], 0);
    ASSERT_EQ(look.textures.size(), 1u);
    EXPECT_EQ(look.textures[0]["source"], 0);
    EXPECT_EQ(look.textures[0]["sampler"], 0);
    EXPECT_EQ(look.images[0]["name"], "i1");
    EXPECT_EQ(look.samplers[0]["magFilter"], 9729);
    EXPECT_EQ(look.imageData, (std::vector<std::vector<std::uint8_t>>{{3, 4}}));
}

}  // namespace
}  // namespace mucosa::test
