#include <mucosa/scene/scene.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/phantom.hpp>
#include <mucosa/mesh/primitives.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/mesh/uv.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/reflectance/tissue_texture.hpp>
#include <mucosa/shading/brdf.hpp>

#include "core/json_parse.hpp"

namespace mucosa::scene {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// The default tube (used when the phantom is not available, or asked for).
constexpr float kTubeRadius = 7.0f, kTubeLength = 150.0f;
constexpr int kTubeAround = 24, kTubeAlong = 60;
constexpr int kTissueTextureSize = 512;
// mm the default fly-through keeps between the near plane and the wall a
// centerline's distal end closes against (beyond the lumen's radius there).
constexpr float kStopMarginMm = 3.0f;

struct Parser {
    std::string file;
    fs::path dir;

    static std::string typeName(const json& j) {
        if (j.is_null()) return "null";
        if (j.is_boolean()) return "a boolean";
        if (j.is_number()) return "a number";
        if (j.is_string()) return "a string";
        if (j.is_array()) return "an array";
        return "an object";
    }
    [[noreturn]] void fail(const std::string& field, const std::string& why) const {
        throw InputError(field, file, why);
    }

    void object(const json& j, const std::string& field) const {
        if (!j.is_object()) fail(field, "must be an object, not " + typeName(j));
    }
    void known(const json& j, const std::string& prefix, std::initializer_list<std::string_view> keys) const {
        known(j, prefix, std::vector<std::string_view>(keys));
    }
    void known(const json& j, const std::string& prefix, const std::vector<std::string_view>& keys) const {
        for (auto it = j.begin(); it != j.end(); ++it)
            if (std::find(keys.begin(), keys.end(), it.key()) == keys.end()) {
                std::string list;
                for (std::string_view k : keys) list += (list.empty() ? "" : ", ") + std::string(k);
                fail(prefix + it.key(), "unknown key (known here: " + list + ")");
            }
    }
    double number(const json& j, const std::string& field) const {
        if (!j.is_number()) fail(field, "must be a number, not " + typeName(j));
        const double v = j.get<double>();
        if (!std::isfinite(v)) fail(field, "must be finite");
        return v;
    }
    float positive(const json& j, const std::string& field) const {
        const double v = number(j, field);
        if (!(v > 0)) fail(field, fmt::format("must be positive, not {}", v));
        return static_cast<float>(v);
    }
    int integer(const json& j, const std::string& field, int lo, int hi) const {
        if (!j.is_number_integer()) fail(field, "must be an integer, not " + typeName(j));
        try {
            return detail::wholeNumber<int>(j, field, file, lo, hi);
        } catch (const InputError& e) {
            fail(field, e.reason());
        }
    }
    bool boolean(const json& j, const std::string& field) const {
        if (!j.is_boolean()) fail(field, "must be true or false, not " + typeName(j));
        return j.get<bool>();
    }
    std::string string(const json& j, const std::string& field) const {
        if (!j.is_string()) fail(field, "must be a string, not " + typeName(j));
        return j.get<std::string>();
    }
    fs::path path(const json& j, const std::string& field) const {
        const std::string s = string(j, field);
        if (s.empty()) fail(field, "must not be empty");
        const fs::path p(s);
        return p.is_absolute() || dir.empty() ? p : dir / p;
    }
    std::array<float, 3> vec3(const json& j, const std::string& field) const {
        if (!j.is_array() || j.size() != 3) fail(field, "must be an array of 3 numbers");
        std::array<float, 3> r{};
        for (std::size_t i = 0; i < 3; ++i) r[i] = static_cast<float>(number(j[i], fmt::format("{}[{}]", field, i)));
        return r;
    }

    camera::Pose pose(const json& j, const std::string& f) const {
        object(j, f);
        known(j, f + ".", {"position", "look_at", "forward", "up"});
        if (!j.contains("position")) fail(f + ".position", "is missing");
        camera::Pose p;
        p.position = vec3(j["position"], f + ".position");
        if (j.contains("up")) p.up = vec3(j["up"], f + ".up");
        if (j.contains("look_at") == j.contains("forward")) fail(f, "needs exactly one of look_at and forward");
        if (j.contains("look_at")) {
            const auto t = vec3(j["look_at"], f + ".look_at");
            if (t == p.position) fail(f + ".look_at", "must differ from position");
            p = camera::lookAt(p.position, t, p.up);
        } else {
            p.forward = vec3(j["forward"], f + ".forward");
            if (p.forward == camera::Vec3{0, 0, 0}) fail(f + ".forward", "must not be zero");
        }
        return p;
    }

    void registryGroup(const json& j, const std::string& group, shading::ParamSet& params,
                       std::initializer_list<std::string_view> extra = {}) const {
        object(j, group);
        for (auto it = j.begin(); it != j.end(); ++it) {
            const std::string field = group + "." + it.key();
            if (std::find(extra.begin(), extra.end(), it.key()) != extra.end()) continue;
            const shading::ParamInfo* pi = shading::findParam(it.key());
            if (pi == nullptr || pi->group != group) {
                std::string list;
                for (const auto& q : shading::registry())
                    if (q.group == group) list += (list.empty() ? "" : ", ") + std::string(q.name);
                for (std::string_view k : extra) list += ", " + std::string(k);
                fail(field, "unknown parameter (known here: " + list + ")");
            }
            if (pi->components == 3)
                params.setColor(pi->id, vec3(it.value(), field), file, field);
            else
                params.set(pi->id, static_cast<float>(number(it.value(), field)), file, field);
        }
    }

    // The keys of `j` applied to `base` (a "preset" key replaces it first).
    reflectance::MapParams mapParams(const json& j, const std::string& f, const reflectance::MapParams& base) const {
        object(j, f);
        std::vector<std::string_view> keys = {"preset"};
        for (const reflectance::MapParamInfo& i : reflectance::mapRegistry())
            if (i.id != reflectance::MapParam::Bits) keys.push_back(i.name);  // a rendered map is 8-bit
        known(j, f + ".", keys);
        reflectance::MapParams p = base;
        if (j.contains("preset")) {
            const std::string name = string(j["preset"], f + ".preset");
            try {
                p = reflectance::findPreset(name).params;
            } catch (const InputError& e) {
                fail(f + ".preset", e.reason());
            }
        }
        for (const reflectance::MapParamInfo& i : reflectance::mapRegistry()) {
            const std::string key(i.name), field = f + "." + key;
            if (i.id == reflectance::MapParam::Bits || !j.contains(key)) continue;
            try {
                reflectance::set(p, i.id, j[key], field, file);
            } catch (const InputError& e) {
                fail(field, e.reason());
            }
        }
        if (p.size > reflectance::kMaxRenderedMapSize)
            fail(f + ".size", fmt::format("{} is larger than a rendered map can be ({} texels)", p.size,
                                          reflectance::kMaxRenderedMapSize));
        p.bits = 8;
        try {
            reflectance::validate(p);
        } catch (const InputError& e) {
            fail(f + "." + e.subject(), e.reason());
        }
        return p;
    }
};

}  // namespace

void setMapParameter(Scene& scene, const std::string& key, const std::string& value) {
    const Parser P{"", {}};
    const json v = reflectance::parameterValue(value);  // a string: a preset name
    json j = json::object();
    j[key] = v;
    scene.mapParams = P.mapParams(j, "--set reflectance_map", scene.mapParams);
    scene.reflectanceMap.reset();  // the map is generated from these parameters, as the procedural mode reads them
}

namespace {

// The kinds' names, in enum order (static_asserts below).
constexpr std::array<std::string_view, 3> kMeshKindNames{"phantom", "tube", "file"};
constexpr std::array<std::string_view, 3> kPathKindNames{"none", "poses", "centerline"};
static_assert(static_cast<std::size_t>(MeshKind::Phantom) == 0 && static_cast<std::size_t>(MeshKind::Tube) == 1 &&
              static_cast<std::size_t>(MeshKind::File) == 2 && kMeshKindNames.size() == 3);
static_assert(static_cast<std::size_t>(PathKind::None) == 0 && static_cast<std::size_t>(PathKind::Poses) == 1 &&
              static_cast<std::size_t>(PathKind::Centerline) == 2 && kPathKindNames.size() == 3);

template <class Kind, std::size_t N>
Kind parseKind(const std::array<std::string_view, N>& names, std::string_view name, const char* what,
               const std::string& field, const std::string& file) {
    std::string list;
    for (std::size_t i = 0; i < N; ++i) {
        if (names[i] == name) return static_cast<Kind>(i);
        list += (list.empty() ? "" : ", ") + std::string(names[i]);
    }
    throw InputError(field, file, fmt::format("unknown {} '{}' (known: {})", what, name, list));
}

}  // namespace

std::string_view meshKindName(MeshKind kind) noexcept {
    return kMeshKindNames[static_cast<std::size_t>(kind)];
}

std::string_view pathKindName(PathKind kind) noexcept {
    return kPathKindNames[static_cast<std::size_t>(kind)];
}

MeshKind parseMeshKind(std::string_view name, const std::string& field, const std::string& file) {
    return parseKind<MeshKind>(kMeshKindNames, name, "mesh kind", field, file);
}

PathKind parsePathKind(std::string_view name, const std::string& field, const std::string& file) {
    return parseKind<PathKind>(kPathKindNames, name, "camera path kind", field, file);
}

namespace {

// A fly-through's polyline and the lumen radius at its distal end (where
// the flight stops short of the wall; 0 = unknown).
struct FlightPath {
    std::vector<mesh::Vec3> points;
    float endRadius = 0;
    std::vector<float> radii;  // one per point, or empty when a branch on the way has none
    mesh::Centerline tree;     // the tree the path was taken from
};

void setPath(SceneAssets& a, FlightPath&& p) {
    a.centerline = std::move(p.points);
    a.centerlineEndRadius = p.endRadius;
    a.centerlineRadii = std::move(p.radii);
    a.centerlineTree = std::move(p.tree);
}

FlightPath pathTo(const mesh::Centerline& c, int branch) {
    const std::vector<float>& radii = c.branches[static_cast<std::size_t>(branch)].radii;
    FlightPath p{mesh::pathToBranch(c, branch), radii.empty() ? 0.0f : radii.back(), {}, {}};
    // The radii along the path, point for point as pathToBranch joins the branches.
    std::vector<int> chain;
    for (int b = branch; b >= 0; b = c.branches[static_cast<std::size_t>(b)].parent) chain.push_back(b);
    std::vector<mesh::Vec3> joined;
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
        const mesh::CenterlineBranch& br = c.branches[static_cast<std::size_t>(*it)];
        if (br.radii.size() != br.points.size()) return p;
        for (std::size_t i = 0; i < br.points.size(); ++i)
            if (joined.empty() || joined.back() != br.points[i])
                joined.push_back(br.points[i]), p.radii.push_back(br.radii[i]);
    }
    if (p.radii.size() != p.points.size()) p.radii.clear();
    return p;
}

FlightPath longestPath(const mesh::Centerline& c, int branch, const std::string& file) {
    if (c.branches.empty()) throw InputError("camera.path.centerline", file, "the centerline has no branches");
    if (branch >= static_cast<int>(c.branches.size()))
        throw InputError("camera.path.branch", file,
                         fmt::format("{} is out of range (the centerline has {} branches)", branch, c.branches.size()));
    if (branch >= 0) {
        FlightPath p = pathTo(c, branch);
        p.tree = c;
        return p;
    }
    FlightPath best;
    float bestLen = -1;
    for (std::size_t b = 0; b < c.branches.size(); ++b) {
        FlightPath p = pathTo(c, static_cast<int>(b));
        const float len = camera::pathLength(p.points);
        if (len > bestLen) bestLen = len, best = std::move(p);
    }
    best.tree = c;
    return best;
}

// The scene's sections, one reader each, in the order parseScene runs them.

// "mesh" (required), "lit_side", "closed": the surface and which side of it is lit.
void readMesh(const Parser& P, const json& j, Scene& s) {
    if (!j.contains("mesh")) P.fail("mesh", "is missing (a file, \"phantom\" or \"tube\")");
    const json& m = j["mesh"];
    if (m.is_string()) {
        const std::string v = m.get<std::string>();
        if (v == meshKindName(MeshKind::Phantom) || v == meshKindName(MeshKind::Tube)) {
            s.mesh.kind = parseMeshKind(v, "mesh", P.file);
        } else {
            s.mesh.kind = MeshKind::File;
            s.mesh.file = P.path(m, "mesh");
        }
    } else if (m.is_object()) {
        P.known(m, "mesh.", {"file", "phantom", "tube"});
        if (m.size() != 1) P.fail("mesh", "needs exactly one of file, phantom, tube");
        if (m.contains("file")) {
            s.mesh.kind = MeshKind::File;
            s.mesh.file = P.path(m["file"], "mesh.file");
        } else if (m.contains("tube")) {
            s.mesh.kind = MeshKind::Tube;
        } else {
            const json& ph = m["phantom"];
            P.object(ph, "mesh.phantom");
            P.known(ph, "mesh.phantom.", {"generations", "seed", "resolution"});
            s.mesh.kind = MeshKind::Phantom;
            if (ph.contains("generations"))
                s.mesh.phantomGenerations = P.integer(ph["generations"], "mesh.phantom.generations", 0, 7);
            if (ph.contains("seed"))
                s.mesh.phantomSeed = static_cast<std::uint64_t>(P.integer(ph["seed"], "mesh.phantom.seed", 0, 1 << 30));
            if (ph.contains("resolution"))
                s.mesh.phantomResolution = P.positive(ph["resolution"], "mesh.phantom.resolution");
        }
    } else {
        P.fail("mesh", "must be a file name, \"phantom\", \"tube\" or an object, not " + Parser::typeName(m));
    }
    if (j.contains("lit_side")) {
        const std::string v = P.string(j["lit_side"], "lit_side");
        if (v != "front" && v != "back") P.fail("lit_side", "must be \"front\" or \"back\", not '" + v + "'");
        s.normalSign = v == "front" ? 1.0f : -1.0f;
    }
    if (j.contains("closed")) s.closed = P.boolean(j["closed"], "closed");
}

// "diffuse": a subject texture file, "generated" or "none".
void readDiffuse(const Parser& P, const json& j, Scene& s) {
    if (!j.contains("diffuse")) return;
    s.generatedDiffuse = false;
    if (j["diffuse"].is_string() && j["diffuse"].get<std::string>() == "generated")
        s.generatedDiffuse = true;
    else if (j["diffuse"].is_string() && j["diffuse"].get<std::string>() == "none")
        s.diffuse.reset();
    else
        s.diffuse = P.path(j["diffuse"], "diffuse");
}

// "reflectance_map" (a file or map parameters) and "filter": the map and how it is sampled.
void readReflectanceMap(const Parser& P, const json& j, Scene& s) {
    if (j.contains("reflectance_map")) {
        const json& r = j["reflectance_map"];
        if (r.is_string())
            s.reflectanceMap = P.path(r, "reflectance_map");
        else
            s.mapParams = P.mapParams(r, "reflectance_map", reflectance::findPreset("bronchial").params);
    }
    if (j.contains("filter")) {
        const std::string v = P.string(j["filter"], "filter");
        if (v == "nearest")
            s.filter = shading::Filter::Nearest;
        else if (v == "linear")
            s.filter = shading::Filter::Linear;
        else if (v == "trilinear")
            s.filter = shading::Filter::Trilinear;
        else if (v == "mipmap")
            s.filter = shading::Filter::Mipmap;
        else
            P.fail("filter", "must be nearest, linear, mipmap or trilinear, not '" + v + "'");
    }
}

// "mode", "noise_space", "specular_aa": what the shader computes.
void readShading(const Parser& P, const json& j, Scene& s) {
    if (j.contains("mode")) s.mode = shading::parseMode(P.string(j["mode"], "mode"), "mode", P.file);
    if (j.contains("noise_space")) {
        const std::string v = P.string(j["noise_space"], "noise_space");
        if (v != "uv" && v != "object") P.fail("noise_space", "must be \"uv\" or \"object\", not '" + v + "'");
        s.noiseSpace = v == "uv" ? shading::NoiseSpace::Uv : shading::NoiseSpace::Object;
    }
    if (j.contains("specular_aa")) s.specularAA = P.boolean(j["specular_aa"], "specular_aa");
}

// "material": the registry's material group.
void readMaterial(const Parser& P, const json& j, Scene& s) {
    if (!j.contains("material")) return;
    P.registryGroup(j["material"], "material", s.params);
    for (auto it = j["material"].begin(); it != j["material"].end(); ++it)
        s.fileMaterial.push_back(shading::findParam(it.key())->id);  // registryGroup checked the names
}

// "tissue": the generated texture's parameters by name.
void readTissue(const Parser& P, const json& j, Scene& s) {
    if (!j.contains("tissue")) return;
    P.object(j["tissue"], "tissue");
    for (auto it = j["tissue"].begin(); it != j["tissue"].end(); ++it) {
        const std::string field = "tissue." + it.key();
        setTissueParameter(s, it.key(), P.number(it.value(), field), field, P.file);
    }
}

// "variation": a patient seed (reflectance::drawAppearance), after "material"
// so the file's own mucus_opacity and specular_strength stay.
void readVariation(const Parser& P, const json& j, Scene& s) {
    if (!j.contains("variation")) return;
    const json& v = j["variation"];
    if (!v.is_number_unsigned())
        P.fail("variation", fmt::format("must be a whole number >= 0 (a patient seed; 0 = the default look), not {}",
                                        v.is_number() ? v.dump() : Parser::typeName(v)));
    applyVariation(s, v.get<std::uint64_t>());
}

// "fit": the output folder of mucosa fit: its brdf.json sets c0..c3, d1..d3
// and the depth range, its texture.png is the diffuse texture (unless
// "diffuse" names another); explicit "brdf" values (readBrdfAndLight) override.
void readFit(const Parser& P, const json& j, Scene& s) {
    if (!j.contains("fit")) return;
    const fs::path dir = P.path(j["fit"], "fit");
    shading::BrdfParams b;
    json bj;  // brdf.json, read once: the BRDF and (below) the atlas rectangle
    try {
        bj = detail::parseJsonFile(readTextFile(dir / "brdf.json"), (dir / "brdf.json").string());
        b = shading::brdfFromJson(bj, (dir / "brdf.json").string());
    } catch (const Error& e) {
        P.fail("fit", e.what());
    }
    using shading::Param;
    const Param cs[4] = {Param::C0, Param::C1, Param::C2, Param::C3};
    const Param ds[3] = {Param::D1, Param::D2, Param::D3};
    for (int i = 0; i < 4; ++i)
        s.params.set(cs[i], static_cast<float>(b.c[static_cast<std::size_t>(i)]), P.file, "fit");
    for (int i = 0; i < 3; ++i)
        s.params.set(ds[i], static_cast<float>(b.d[static_cast<std::size_t>(i)]), P.file, "fit");
    s.params.set(Param::DepthMin, static_cast<float>(b.zmin), P.file, "fit");
    s.params.set(Param::DepthMax, static_cast<float>(b.zmax), P.file, "fit");
    if (j.contains("diffuse")) return;
    s.diffuse = dir / "texture.png";
    s.generatedDiffuse = false;
    // The atlas spans the mesh's UV rectangle (brdf.json uv_min, uv_max; [0,
    // 1] unless the UVs leave it, as centerline UVs do).
    if (bj.contains("uv_min") && bj.contains("uv_max")) {
        const auto vec2 = [&](const json& v, const char* key) {
            if (!v.is_array() || v.size() != 2) P.fail("fit", fmt::format("brdf.json: {} must be [u, v]", key));
            return std::array<float, 2>{static_cast<float>(P.number(v[0], "fit")),
                                        static_cast<float>(P.number(v[1], "fit"))};
        };
        const auto lo = vec2(bj["uv_min"], "uv_min"), hi = vec2(bj["uv_max"], "uv_max");
        if (!(hi[0] > lo[0] && hi[1] > lo[1])) P.fail("fit", "brdf.json: uv_max must exceed uv_min");
        s.diffuseUvTransform = {1.0f / (hi[0] - lo[0]), 1.0f / (hi[1] - lo[1]), -lo[0] / (hi[0] - lo[0]),
                                -lo[1] / (hi[1] - lo[1])};
    }
}

// "brdf" and "light": the registry's groups (light also "offset_mm").
void readBrdfAndLight(const Parser& P, const json& j, Scene& s) {
    if (j.contains("brdf")) P.registryGroup(j["brdf"], "brdf", s.params);
    if (j.contains("light")) {
        P.registryGroup(j["light"], "light", s.params, {"offset_mm"});
        if (j["light"].contains("offset_mm")) s.light.offset = P.vec3(j["light"]["offset_mm"], "light.offset_mm");
    }
}

// "resolution", "frames": the output.
void readOutput(const Parser& P, const json& j, Scene& s) {
    if (j.contains("resolution")) {
        const json& r = j["resolution"];
        if (!r.is_array() || r.size() != 2) P.fail("resolution", "must be [width, height]");
        s.width = P.integer(r[0], "resolution[0]", 16, 8192);
        s.height = P.integer(r[1], "resolution[1]", 16, 8192);
    }
    if (j.contains("frames")) s.frames = P.integer(j["frames"], "frames", 1, 1000000);
    if (j.contains("outputs")) {
        const json& o = j["outputs"];
        if (o.is_array()) {
            for (std::size_t i = 0; i < o.size(); ++i)
                s.outputs += (i ? "," : "") + P.string(o[i], fmt::format("outputs[{}]", i));
            if (s.outputs.empty()) P.fail("outputs", "is empty");
        } else {
            s.outputs = P.string(o, "outputs");
        }
    }
}

// "camera.path": key poses, or a fly-through along a centerline.
void readPath(const Parser& P, const json& p, Scene& s) {
    P.object(p, "camera.path");
    P.known(p, "camera.path.",
            {"poses", "centerline", "centreline", "branch", "speed_mm", "start_mm", "stop_mm", "look_ahead_mm",
             "wander", "look_around_deg", "wall_clearance_mm", "wander_period_mm", "seed", "route", "roll_deg",
             "pause_mm", "withdraw_speed"});
    // "centreline": the British spelling, accepted for one release.
    if (p.contains("centreline")) {
        if (p.contains("centerline"))
            P.fail("camera.path.centreline", "give one of centerline and centreline (deprecated), not both");
        s.warnings.push_back(
            describe(InputError("camera.path.centreline", P.file, "'centreline' is deprecated, use 'centerline'")));
    }
    const char* const centerlineKey = p.contains("centreline") ? "centreline" : "centerline";
    if (p.contains("poses") == p.contains(centerlineKey))
        P.fail("camera.path", "needs exactly one of poses and centerline");
    if (p.contains("poses")) {
        const json& list = p["poses"];
        if (!list.is_array() || list.empty()) P.fail("camera.path.poses", "must be a non-empty array of poses");
        s.path.kind = PathKind::Poses;
        for (std::size_t i = 0; i < list.size(); ++i)
            s.path.poses.push_back(P.pose(list[i], fmt::format("camera.path.poses[{}]", i)));
        return;
    }
    s.path.kind = PathKind::Centerline;
    const std::string field = std::string("camera.path.") + centerlineKey;
    const std::string v = P.string(p[centerlineKey], field);
    if (v != "auto") s.path.centerlineFile = P.path(p[centerlineKey], field);
    if (p.contains("branch")) s.path.branch = P.integer(p["branch"], "camera.path.branch", 0, 1 << 20);
    // The route: the bronchoscopist's survey of the whole tree, or one path
    // (the longest, or to "branch").
    if (p.contains("route")) {
        const std::string route = P.string(p["route"], "camera.path.route");
        if (route != "survey" && route != "path")
            P.fail("camera.path.route", fmt::format("unknown route '{}' (known: survey, path)", route));
        if (route == "survey" && p.contains("branch"))
            P.fail("camera.path.route", "a survey covers every branch: give route \"path\" with a branch");
        s.path.survey = route == "survey";
    } else if (p.contains("branch")) {
        s.path.survey = false;
    }
    if (p.contains("roll_deg"))
        s.path.surveyOptions.rollDeg = static_cast<float>(P.number(p["roll_deg"], "camera.path.roll_deg"));
    if (p.contains("pause_mm"))
        s.path.surveyOptions.pauseMm = static_cast<float>(P.number(p["pause_mm"], "camera.path.pause_mm"));
    if (p.contains("withdraw_speed"))
        s.path.surveyOptions.withdrawSpeed =
            static_cast<float>(P.number(p["withdraw_speed"], "camera.path.withdraw_speed"));
    if (p.contains("speed_mm")) s.path.fly.speedMm = P.positive(p["speed_mm"], "camera.path.speed_mm");
    if (p.contains("start_mm")) {
        s.path.fly.startMm = static_cast<float>(P.number(p["start_mm"], "camera.path.start_mm"));
        if (s.path.fly.startMm < 0) P.fail("camera.path.start_mm", "must be >= 0");
    }
    if (p.contains("stop_mm")) {
        s.path.stopMm = static_cast<float>(P.number(p["stop_mm"], "camera.path.stop_mm"));
        if (*s.path.stopMm < 0) P.fail("camera.path.stop_mm", "must be >= 0");
    }
    if (p.contains("look_ahead_mm"))
        s.path.fly.lookAheadMm = P.positive(p["look_ahead_mm"], "camera.path.look_ahead_mm");
    // The bronchoscopist's wandering (camera::FlyThrough): ranges checked there.
    if (p.contains("wander")) s.path.fly.wander = static_cast<float>(P.number(p["wander"], "camera.path.wander"));
    if (p.contains("look_around_deg"))
        s.path.fly.lookAroundDeg = static_cast<float>(P.number(p["look_around_deg"], "camera.path.look_around_deg"));
    if (p.contains("wall_clearance_mm"))
        s.path.fly.wallClearanceMm =
            static_cast<float>(P.number(p["wall_clearance_mm"], "camera.path.wall_clearance_mm"));
    if (p.contains("wander_period_mm"))
        s.path.fly.wanderPeriodMm = P.positive(p["wander_period_mm"], "camera.path.wander_period_mm");
    if (p.contains("seed"))
        s.path.fly.seed = static_cast<std::uint64_t>(P.integer(p["seed"], "camera.path.seed", 0, 1 << 30));
    try {
        camera::validate(s.path.fly);
        camera::validate(s.path.surveyOptions);
    } catch (const InputError& e) {
        P.fail(e.subject(), e.reason());
    }
}

// "camera": the lens, a fixed pose, a path.
void readCamera(const Parser& P, const json& j, Scene& s) {
    if (!j.contains("camera")) return;
    const json& c = j["camera"];
    P.object(c, "camera");
    // The lens and the path, and the registry's camera group (exposure,
    // sensor, tone curve, mask: shaders/camera.glsl).
    P.registryGroup(c, "camera", s.params, {"fov_deg", "near_mm", "far_mm", "lens", "pose", "path"});
    for (auto it = c.begin(); it != c.end(); ++it)
        if (const shading::ParamInfo* q = shading::findParam(it.key()); q != nullptr && q->group == "camera")
            s.fileMaterial.push_back(q->id);  // the variation leaves it as the file sets it
    if (c.contains("lens")) {
        const json& l = c["lens"];
        if (l.is_object()) {
            s.lensModelJson = l.dump();
            s.lensModelFile.clear();
        } else if (l.is_string()) {
            s.lensModelFile = P.path(l, "camera.lens");
            s.lensModelJson.clear();
        } else {
            P.fail("camera.lens", "must be a lens object or the name of a lens file, not " + Parser::typeName(l));
        }
    }
    if (c.contains("fov_deg")) s.lens.fovDeg = static_cast<float>(P.number(c["fov_deg"], "camera.fov_deg"));
    if (c.contains("near_mm")) s.lens.nearMm = static_cast<float>(P.number(c["near_mm"], "camera.near_mm"));
    if (c.contains("far_mm")) s.lens.farMm = static_cast<float>(P.number(c["far_mm"], "camera.far_mm"));
    try {
        camera::validate(s.lens);
    } catch (const InputError& e) {
        P.fail(e.subject(), e.reason());
    }
    if (c.contains("pose")) {
        s.pose = P.pose(c["pose"], "camera.pose");
        s.path.kind = PathKind::None;
    }
    if (c.contains("path")) readPath(P, c["path"], s);
}

}  // namespace

namespace {

// `value` for tissue parameter `key`, checked against its range.
double checkedTissue(const std::string& key, double value, const std::string& field, const std::string& file) {
    const reflectance::TissueParamInfo* info = reflectance::findTissueParam(key);
    if (info == nullptr) {
        std::string list;
        for (const reflectance::TissueParamInfo& i : reflectance::tissueRegistry())
            list += (list.empty() ? "" : ", ") + std::string(i.name);
        throw InputError(field, file, fmt::format("unknown tissue parameter '{}' (known: {})", key, list));
    }
    if (!std::isfinite(value) || value < info->min || value > info->max)
        throw InputError(field, file,
                         fmt::format("{} is outside {}..{}{}{}", value, info->min, info->max,
                                     info->unit.empty() ? "" : " ", info->unit));
    return value;
}

}  // namespace

void setTissueParameter(Scene& scene, const std::string& key, double value, const std::string& field,
                        const std::string& file) {
    scene.tissue[key] = checkedTissue(key, value, field, file);
}

reflectance::TissueParams tissueParams(const Scene& scene) {
    reflectance::TissueParams p = scene.appearance.tissue;
    const reflectance::TissueParams centre = reflectance::defaultAppearance().tissue;
    for (const auto& [key, value] : scene.look.tissue) {
        const reflectance::TissueParamInfo& i = *reflectance::findTissueParam(key);
        const double drawn = p.*i.member, standard = centre.*i.member;
        const double v = i.scales && standard > 0 ? value * drawn / standard : value + (drawn - standard);
        p.*i.member = std::clamp(v, i.min, i.max);
    }
    for (const auto& [key, value] : scene.tissue) p.*(reflectance::findTissueParam(key)->member) = value;
    return p;
}

void applyVariation(Scene& scene, std::uint64_t seed) {
    scene.variation = seed;
    const double previousEv = scene.appearance.exposureEv;  // a seed applied before: replaced, not compounded
    scene.appearance = reflectance::drawAppearance(seed);
    // Scaled from the default scene's values, or a look's (not compounded
    // with a seed applied before).
    shading::ParamSet defaults = defaultScene().params;
    for (const auto& [p, v] : scene.look.params) defaults.set(p, v);
    const auto scale = [&](shading::Param p, double factor) {
        if (std::find(scene.fileMaterial.begin(), scene.fileMaterial.end(), p) != scene.fileMaterial.end()) return;
        const shading::ParamInfo& info = shading::info(p);
        scene.params.set(p, std::clamp(static_cast<float>(defaults[p] * factor), info.min, info.max), "", "variation");
    };
    scale(shading::Param::MucusOpacity, reflectance::mucusOpacityScale(scene.appearance.mucus));
    scale(shading::Param::SpecularStrength, reflectance::specularScale(scene.appearance.mucus));
    // The scope and its processor.
    const double noise = scene.appearance.noise;
    scale(shading::Param::Softness, scene.appearance.softness);
    scale(shading::Param::ReadNoise, noise);
    scale(shading::Param::FullWell, 1.0 / (noise * noise));
    scale(shading::Param::Flare, scene.appearance.flare);
    // The patient's exposure offset: auto-exposure's compensation (or the
    // fixed exposure), on top of what the scene sets.
    const shading::ParamInfo& ev = shading::info(shading::Param::ExposureEv);
    const float base = scene.params[shading::Param::ExposureEv] - static_cast<float>(previousEv);
    scene.params.set(shading::Param::ExposureEv,
                     std::clamp(base + static_cast<float>(scene.appearance.exposureEv), ev.min, ev.max), "",
                     "variation");
}

Scene defaultScene() {
    Scene s;
    // The airway preset: the paper's method with gentler bumps than its
    // "bronchial" look, whose dense small glints glitter along the near
    // walls; real highlights are few and larger. With them, k_s 1.2 instead
    // of the paper's 2 (docs/theory.md, "Wet tissue").
    s.mapParams = reflectance::findPreset("airway").params;
    s.mapParams.bits = 8;
    s.path.kind = PathKind::Centerline;
    s.path.fly.frames = 120;
    // A bronchoscopist's survey of the whole tree (camera::surveyTree): off
    // the centre by up to 80 % of the lumen's radius and 1.2 mm from the
    // wall, the view turning up to 40 degrees to the walls and openings, the
    // scope rolling up to 30 degrees (docs/theory.md, "The bronchoscopist's
    // survey", for the views this gives).
    s.path.fly.wander = 0.8f;
    s.path.fly.lookAroundDeg = 40.0f;
    s.path.fly.wallClearanceMm = 1.2f;
    s.path.fly.wanderPeriodMm = 30.0f;
    s.generatedDiffuse = true;
    // The generated texture carries the tissue colour (docs/theory.md,
    // "Tissue texture"): base_color would tint it a second time.
    s.params.setColor(shading::Param::BaseColor, {1, 1, 1});
    s.params.set(shading::Param::SpecularStrength, 1.2f);
    // The phantom at 1 grid cell per mm (~150 k triangles): real-time on a
    // CPU rasteriser, and the light has faded to ~5 % at the far plane.
    s.mesh.phantomResolution = 1.0;
    s.lens.farMm = 160.0f;
    return s;
}

Scene parseScene(const std::string& text, const fs::path& fileForErrors) {
    const Parser P{fileForErrors.string(), fileForErrors.parent_path()};
    const json j = detail::parseJsonFile(text, P.file);
    P.object(j, "scene");
    P.known(
        j, "",
        {"mesh", "lit_side", "closed", "diffuse", "reflectance_map", "filter", "mode", "material", "fit", "brdf",
         "light", "camera", "resolution", "frames", "outputs", "noise_space", "specular_aa", "variation", "tissue"});
    Scene s = defaultScene();
    s.file = fileForErrors;
    readMesh(P, j, s);
    readDiffuse(P, j, s);
    readReflectanceMap(P, j, s);
    readShading(P, j, s);
    readMaterial(P, j, s);
    readVariation(P, j, s);
    readTissue(P, j, s);
    readFit(P, j, s);
    readBrdfAndLight(P, j, s);
    readOutput(P, j, s);
    readCamera(P, j, s);
    // base_color: white over the generated texture (defaultScene); over a
    // texture file, or none, the registry's tissue colour, unless the file
    // sets it.
    if (!s.generatedDiffuse &&
        std::find(s.fileMaterial.begin(), s.fileMaterial.end(), shading::Param::BaseColor) == s.fileMaterial.end())
        s.params.setColor(shading::Param::BaseColor, shading::ParamSet().color(shading::Param::BaseColor));
    return s;
}

void applyLook(Scene& s, const fs::path& file) {
    const Parser P{file.string(), file.parent_path()};
    const json j = detail::parseJsonFile(readTextFile(file), P.file);
    P.object(j, "look");
    P.known(j, "", {"material", "light", "camera", "tissue", "reflectance_map"});
    Scene::Look look;
    for (const char* group : {"material", "light", "camera"}) {
        if (!j.contains(group)) continue;
        shading::ParamSet values = s.params;
        P.registryGroup(j[group], group, values);
        for (auto it = j[group].begin(); it != j[group].end(); ++it) {
            const shading::Param id = shading::findParam(it.key())->id;  // registryGroup checked the names
            if (shading::info(id).components == 3)
                s.params.setColor(id, values.color(id));
            else
                look.params.push_back({id, values[id]});
        }
    }
    if (j.contains("tissue")) {
        P.object(j["tissue"], "tissue");
        for (auto it = j["tissue"].begin(); it != j["tissue"].end(); ++it) {
            const std::string field = "tissue." + it.key();
            look.tissue[it.key()] = checkedTissue(it.key(), P.number(it.value(), field), field, P.file);
        }
    }
    if (j.contains("reflectance_map")) {
        s.mapParams = P.mapParams(j["reflectance_map"], "reflectance_map", s.mapParams);
        s.reflectanceMap.reset();  // generated from these parameters
    }
    applyLook(s, look);
}

void applyLook(Scene& s, const Scene::Look& look) {
    for (const auto& [p, v] : look.params) {
        // The exposure carries the patient's offset on top (applyVariation takes it off again).
        const float offset = p == shading::Param::ExposureEv ? static_cast<float>(s.appearance.exposureEv) : 0.0f;
        const shading::ParamInfo& i = shading::info(p);
        s.params.set(p, std::clamp(v + offset, i.min, i.max));
    }
    s.look = look;
    // The scene's patient, drawn again about the look.
    if (s.variation != 0) applyVariation(s, s.variation);
}

Scene loadSceneOrLook(const fs::path& file) {
    if (!fs::exists(file)) throw IoError("look", file.string(), "does not exist");
    const json j = detail::parseJsonFile(readTextFile(file), file.string());
    if (!j.is_object() || j.contains("mesh")) return loadScene(file);
    Scene s = defaultScene();
    applyLook(s, file);
    return s;
}

Scene meshScene(const fs::path& meshFile) {
    Scene s = defaultScene();
    s.file = meshFile;
    s.mesh.kind = MeshKind::File;
    s.mesh.file = meshFile;
    return s;
}

Scene loadScene(const fs::path& path) {
    if (!fs::exists(path)) throw IoError("scene file", path.string(), "does not exist");
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext != ".json" && mesh::isMeshFile(path)) return meshScene(path);
    return parseScene(readTextFile(path), path);
}

namespace {

// A file a scene field names must exist: else one line naming the field, the
// scene and the file (as the scene names it, relative to the scene's folder
// when it is inside).
void requireFile(const Scene& scene, const std::string& field, const fs::path& path) {
    std::error_code ec;
    if (fs::exists(path, ec)) return;
    fs::path shown = path;
    if (!scene.file.empty()) {
        const fs::path rel = path.lexically_relative(scene.file.parent_path());
        if (!rel.empty() && *rel.begin() != "..") shown = rel;
    }
    throw InputError(field, scene.file.string(), shown.string() + " does not exist");
}

// A centerline file beside a mesh: <stem>.centerline.json (what mucosa
// phantom writes next to its mesh), else airway.centerline.json.
std::optional<fs::path> centerlineBeside(const fs::path& meshFile) {
    for (const fs::path& p : {meshFile.parent_path() / (meshFile.stem().string() + ".centerline.json"),
                              meshFile.parent_path() / "airway.centerline.json"}) {
        std::error_code ec;
        if (fs::is_regular_file(p, ec)) return p;
    }
    return std::nullopt;
}

// A computed centerline without its stubs: leaf branches shorter than their
// radius are level-set rings at a cap, an open end or a bifurcation's corner,
// not tubes to fly into (the CT airway's longest path would otherwise end in
// one, on the wall). Removed until none is left; parents keep their order.
mesh::Centerline withoutStubs(const mesh::Centerline& c) {
    const std::size_t n = c.branches.size();
    std::vector<char> removed(n, 0);
    std::size_t kept = n;
    for (bool changed = true; changed && kept > 1;) {
        changed = false;
        std::vector<int> children(n, 0);
        for (std::size_t b = 0; b < n; ++b)
            if (!removed[b] && c.branches[b].parent >= 0) ++children[static_cast<std::size_t>(c.branches[b].parent)];
        for (std::size_t b = 0; b < n && kept > 1; ++b) {
            const mesh::CenterlineBranch& br = c.branches[b];
            const float radius = br.radii.empty() ? 0.0f : br.radii.front();
            if (!removed[b] && children[b] == 0 && camera::pathLength(br.points) < radius)
                removed[b] = 1, --kept, changed = true;
        }
    }
    mesh::Centerline out;
    out.axes = c.axes;
    std::vector<int> index(n, -1);
    for (std::size_t b = 0; b < n; ++b) {
        if (removed[b]) continue;
        index[b] = static_cast<int>(out.branches.size());
        out.branches.push_back(c.branches[b]);
        const int parent = c.branches[b].parent;
        out.branches.back().parent = parent >= 0 ? index[static_cast<std::size_t>(parent)] : -1;
    }
    return out;
}

// The fly-through of a mesh file with "centerline": "auto": a centerline file
// beside it, else the one its shape gives (the level-set centerline that
// centerline UVs follow, computed on a copy: the mesh keeps its UVs).
FlightPath meshFileCenterline(const Scene& scene, const mesh::Mesh& shape, std::vector<std::string>& notes) {
    if (const auto beside = centerlineBeside(scene.mesh.file)) {
        FlightPath p = longestPath(mesh::readCenterlineJson(*beside), scene.path.branch, beside->string());
        notes.push_back(fmt::format("centerline: {} (beside the mesh), {:.0f} mm path", beside->string(),
                                    camera::pathLength(p.points)));
        return p;
    }
    mesh::Mesh copy;
    copy.positions = shape.positions;
    copy.indices = shape.indices;
    mesh::CenterlineUvReport r;
    try {
        r = mesh::computeCenterlineUvs(copy);
    } catch (const InputError& e) {
        throw InputError("camera.path.centerline", scene.file.string(),
                         fmt::format("none beside the mesh ({}.centerline.json) and none computed from it ({}): "
                                     "give camera.pose or camera.path",
                                     scene.mesh.file.stem().string(), e.reason()));
    }
    const mesh::Centerline c = withoutStubs(r.centerline);
    FlightPath p = longestPath(c, scene.path.branch, scene.file.string());
    notes.push_back(fmt::format("centerline: computed from the mesh ({} branches), {:.0f} mm path", c.branches.size(),
                                camera::pathLength(p.points)));
    return p;
}

// The mode that draws what `mode` draws from run-time noise, which in object
// space needs no texture coordinates.
std::string_view procedurallyAs(shading::Mode mode) {
    switch (mode) {
        case shading::Mode::Normals:
        case shading::Mode::ProceduralNormals:
            return "procedural-normals";
        case shading::Mode::Clearcoat:
        case shading::Mode::ClearcoatProcedural:
            return "clearcoat-procedural";
        default:
            return "procedural";
    }
}

}  // namespace

void loadTextures(const Scene& scene, SceneAssets& a, int threads, bool reflectanceMap) {
    if (scene.diffuse) {
        requireFile(scene, "diffuse", *scene.diffuse);
        a.diffuse = image::to8(image::readPng(*scene.diffuse));
    } else if (scene.generatedDiffuse) {
        a.diffuse = reflectance::tissueTexture(tissueParams(scene), kTissueTextureSize);
        if (scene.variation != 0) {
            const reflectance::Appearance& v = scene.appearance;
            a.notes.push_back(fmt::format(
                "variation {}: tissue hue {:.0f} deg (tone {:.2f}), vessels x{:.2f} at {:.2f} mm, mucus {:.2f}, "
                "exposure {:+.2f} EV",
                scene.variation, v.tissue.hue, v.tone, v.tissue.vesselDensity, v.tissue.vesselDepth, v.mucus,
                v.exposureEv));
        }
    }
    if (scene.reflectanceMap) {
        requireFile(scene, "reflectance_map", *scene.reflectanceMap);
        a.reflectanceMap = image::to8(image::readPng(*scene.reflectanceMap));
        if (a.reflectanceMap.channels() < 3)
            throw InputError("reflectance_map", scene.reflectanceMap->string(), "must be an RGB image");
        a.notes.push_back("reflectance map: " + scene.reflectanceMap->string());
    } else if (reflectanceMap) {
        const image::ImageF h = reflectance::heightField(scene.mapParams, threads);
        a.reflectanceMap = reflectance::encodeNormals8(
            h, scene.mapParams.strength,
            scene.mapParams.noise.tileable ? reflectance::Edges::Wrap : reflectance::Edges::Clamp, threads);
        a.notes.push_back(fmt::format("reflectance map generated: '{}' preset, frequency {}, {}x{}",
                                      scene.mapParams.preset.empty() ? "custom" : scene.mapParams.preset,
                                      scene.mapParams.noise.frequency, scene.mapParams.size, scene.mapParams.size));
    }
}

SceneAssets loadAssets(const Scene& scene, int threads, bool reflectanceMap) {
    SceneAssets a;
    const std::string file = scene.file.string();
    if (scene.mesh.kind == MeshKind::Phantom) {
        mesh::PhantomParams pp;
        pp.generations = scene.mesh.phantomGenerations;
        pp.seed = scene.mesh.phantomSeed;
        pp.resolution = scene.mesh.phantomResolution;
        mesh::Phantom ph = mesh::makePhantom(pp, threads);
        a.mesh = std::move(ph.mesh);
        setPath(a, longestPath(ph.centerline, scene.path.branch, file));
        a.notes.push_back(fmt::format("phantom: {} generations, {} triangles", pp.generations, a.mesh.triangleCount()));
    } else if (scene.mesh.kind == MeshKind::Tube) {
        a.mesh = mesh::makeTube(kTubeRadius, kTubeLength, kTubeAround, kTubeAlong);
        a.centerline = mesh::tubeCenterline(kTubeLength, 64);
        a.centerlineEndRadius = kTubeRadius;
        a.centerlineRadii.assign(a.centerline.size(), kTubeRadius);
        a.notes.push_back(fmt::format("tube: radius {} mm, length {} mm, {} triangles", kTubeRadius, kTubeLength,
                                      a.mesh.triangleCount()));
    } else {
        requireFile(scene, "mesh", scene.mesh.file);
        mesh::LoadInfo info;
        a.mesh = mesh::load(scene.mesh.file, {}, &info);
        for (const std::string& w : info.warnings) a.notes.push_back("mesh: " + w);
        if (!a.mesh.hasUvs()) {
            shading::FrameSetup f;
            f.mode = scene.mode;
            f.procedural.space = scene.noiseSpace;
            if (shading::modeNeedsUvs(f))
                throw InputError("mesh", scene.mesh.file.string(),
                                 fmt::format("has no texture coordinates, which mode '{}' needs (render it with "
                                             "--mode {} --noise-space object, or add UVs with mucosa mesh "
                                             "--uv centerline)",
                                             shading::modeName(scene.mode), procedurallyAs(scene.mode)));
            a.notes.push_back(
                "mesh: no texture coordinates; modes that read none only (procedural, procedural-normals and "
                "clearcoat-procedural in object space, vertex-phong, multitexture, diffuse, depth)");
        } else if (!a.mesh.hasTangents()) {
            const mesh::TangentReport r = mesh::computeTangents(a.mesh, threads);
            a.notes.push_back(fmt::format("tangents computed ({} degenerate-UV triangles, {} mirrored vertices)",
                                          r.degenerateUvTriangles, r.mirroredVertices));
        }
        a.notes.push_back(fmt::format("mesh: {} ({} triangles)", scene.mesh.file.string(), a.mesh.triangleCount()));
        if (scene.path.kind == PathKind::Centerline && scene.path.centerlineFile.empty()) {
            setPath(a, meshFileCenterline(scene, a.mesh, a.notes));
        }
    }
    if (scene.path.kind == PathKind::Centerline && !scene.path.centerlineFile.empty()) {
        requireFile(scene, "camera.path.centerline", scene.path.centerlineFile);
        setPath(a, longestPath(mesh::readCenterlineJson(scene.path.centerlineFile), scene.path.branch,
                               scene.path.centerlineFile.string()));
    }
    loadTextures(scene, a, threads, reflectanceMap);
    a.highlight = shading::highlightSphereMap(shading::kHighlightTextureSize, scene.params[shading::Param::Shininess]);
    return a;
}

std::string setFlightPath(SceneAssets& a, const mesh::Centerline& centerline, int branch, const std::string& file) {
    const mesh::Centerline c = withoutStubs(centerline);
    FlightPath p = longestPath(c, branch, file);
    const mesh::Vec3 end = p.points.empty() ? mesh::Vec3{} : p.points.back();
    const bool any = !p.points.empty();
    setPath(a, std::move(p));
    // The branch the path ends in: the one whose last point it ends on.
    for (const mesh::CenterlineBranch& b : c.branches)
        if (!b.points.empty() && any && b.points.back() == end) return b.name;
    return {};
}

std::vector<camera::Pose> cameraPoses(const Scene& scene, const SceneAssets& assets, int frames) {
    if (frames < 1) throw InputError("frames", "", "must be at least 1");
    if (scene.path.kind == PathKind::None || (scene.pose && frames == 1)) {
        if (scene.pose) return std::vector<camera::Pose>(static_cast<std::size_t>(frames), *scene.pose);
    }
    if (scene.path.kind == PathKind::Poses) return camera::interpolatePoses(scene.path.poses, frames);
    if (assets.centerline.size() < 2)
        throw InputError("camera.path", scene.file.string(),
                         "the mesh has no centerline to fly along: give camera.pose or camera.path");
    camera::FlyThrough fly = scene.path.fly;
    fly.frames = frames;
    if (scene.path.survey && scene.path.branch < 0 && !assets.centerlineTree.branches.empty())
        return camera::surveyTree(assets.centerlineTree, fly, scene.path.surveyOptions,
                                  scene.path.stopMm.value_or(scene.lens.nearMm + kStopMarginMm));
    // Stop short of the distal end, where a blind bronchus closes: the near
    // plane, the lumen's radius there (the cap's depth) and a margin.
    fly.stopMm = scene.path.stopMm.value_or(scene.lens.nearMm + assets.centerlineEndRadius + kStopMarginMm);
    // Off-centre wandering needs the lumen's radius along the path (none: on the line).
    return camera::flyThrough(assets.centerline, fly, assets.centerlineRadii);
}

shading::FrameSetup frameSetup(const Scene& scene, const camera::Pose& pose, int width, int height) {
    shading::FrameSetup f;
    f.view = camera::viewMatrix(pose);
    f.projection = camera::projectionMatrix(scene.lens, width, height);
    f.eye = pose.position;
    f.light = camera::lightPosition(pose, scene.light);
    f.normalSign = scene.normalSign;
    f.cullBackFaces = scene.closed.value_or(scene.mesh.kind == MeshKind::Phantom);
    f.mode = scene.mode;
    f.params = scene.params;
    f.procedural.noise = scene.mapParams.noise;
    f.procedural.strength = static_cast<float>(scene.mapParams.strength);
    f.procedural.space = scene.noiseSpace;
    f.procedural.texels = scene.mapParams.size;
    f.specularAA = scene.specularAA;
    f.diffuseUvTransform = scene.diffuseUvTransform;
    f.width = width;
    f.height = height;
    return f;
}

shading::Textures referenceTextures(const Scene& scene, const SceneAssets& assets) {
    shading::Textures t;
    const shading::Filter f = scene.filter == shading::Filter::Trilinear || scene.filter == shading::Filter::Mipmap
                                  ? shading::Filter::Linear
                                  : scene.filter;
    if (!assets.diffuse.empty()) t.diffuse = {&assets.diffuse, f, shading::Wrap::Repeat};
    if (!assets.reflectanceMap.empty()) t.reflectance = {&assets.reflectanceMap, f, shading::Wrap::Repeat};
    t.highlight = {&assets.highlight, shading::Filter::Linear, shading::Wrap::Clamp};  // as Renderer uploads it
    return t;
}

}  // namespace mucosa::scene
