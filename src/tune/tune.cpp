#include <mucosa/tune/tune.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/text.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/reflectance/tissue_texture.hpp>
#include <mucosa/render/offscreen.hpp>
#include <mucosa/scene/scene.hpp>
#include <mucosa/shading/params.hpp>

#include "pattern_search.hpp"

namespace mucosa::tune {

using json = nlohmann::json;

namespace {

constexpr std::string_view kMapPrefix = "reflectance_map.";

// Ranges: where the highlights change, inside the registries' ranges. The
// frequency is a whole number because the tissue presets are tileable maps
// (reflectance::validate); 2..128 cycles per map at map_tiling 4 spans
// bumps from a quarter of the airway's circumference down to the texel scale
// of a 1024 map. Strength 0.001..0.04 spans mean normal tilts of ~2 to ~45 deg.
//
// The look's parameters (tune/look.hpp; lookParams() lists them by group):
// ranges about the default look wide enough for the scopes and patients of
// real frames, inside the registries' ranges.
constexpr std::array<TuneParam, 26> kTuneParams = {{
    {"reflectance_map.frequency", 2, 128, true, true, "frequency (cycles/map)"},
    {"reflectance_map.octaves", 1, 8, false, true, "octaves"},
    {"reflectance_map.gain", 0.2, 0.8, false, false, "gain (persistence)"},
    {"reflectance_map.strength", 0.001, 0.04, true, false, "strength B (map widths)"},
    {"material.shininess", 5, 400, true, false, "shininess n"},
    {"material.specular_strength", 0.1, 3, true, false, "specular strength k_s"},
    {"material.bump_scale", 0.1, 4, true, false, "bump scale"},
    {"material.map_tiling", 1, 16, true, false, "map tiling (1/uv)"},
    {"tissue.lightness", 40, 85, false, false, "mucosa lightness L*"},
    {"tissue.chroma", 10, 60, false, false, "mucosa chroma C*"},
    {"tissue.hue", 15, 70, false, false, "mucosa hue (deg)"},
    {"tissue.hue_variation", 1, 20, true, false, "patchiness of hue (deg)"},
    {"tissue.mottle", 0.5, 10, true, false, "mottle (L*)"},
    {"tissue.vessel_density", 0.25, 4, true, false, "vessel density (x)"},
    {"tissue.vessel_contrast", 0.1, 1, false, false, "vessel contrast"},
    {"material.mucus_opacity", 0.02, 0.6, true, false, "mucus opacity"},
    {"material.sheen", 0.05, 1, true, false, "wet sheen"},
    {"camera.auto_key", 0.06, 0.6, true, false, "exposure key"},
    {"camera.vignetting", 0, 4, false, false, "vignetting (cos^k)"},
    {"light.spread", 0, 4, false, false, "lamp spread"},
    {"camera.flare", 0.002, 0.2, true, false, "veiling glare"},
    {"camera.softness_px", 0.05, 1.2, true, false, "optical softness (px)"},
    {"camera.read_noise", 0.0001, 0.02, true, false, "read noise"},
    {"camera.full_well", 500, 200000, true, false, "full well (e-)"},
    {"camera.saturation", 0.7, 3, true, false, "colour saturation"},
    {"camera.knee", 0.5, 1, false, false, "highlight knee"},
}};
constexpr std::size_t kDefaultTuneCount = 6;

constexpr std::string_view kTissuePrefix = "tissue.";

bool isMap(const TuneParam& p) {
    return p.key.starts_with(kMapPrefix);
}

bool isTissue(const TuneParam& p) {
    return p.key.starts_with(kTissuePrefix);
}

const reflectance::TissueParamInfo& tissueInfo(const TuneParam& p) {
    const reflectance::TissueParamInfo* i = reflectance::findTissueParam(p.key.substr(kTissuePrefix.size()));
    MUCOSA_CHECK(i != nullptr, "a tunable tissue parameter that is not in the tissue registry");
    return *i;
}

const reflectance::MapParamInfo& mapInfo(const TuneParam& p) {
    const reflectance::MapParamInfo* i = reflectance::findMapParam(p.key.substr(kMapPrefix.size()));
    MUCOSA_CHECK(i != nullptr, "a tunable map parameter that is not in the map registry");
    return *i;
}

const shading::ParamInfo& materialInfo(const TuneParam& p) {
    const shading::ParamInfo* i = shading::findParam(p.key.substr(p.key.find('.') + 1));
    MUCOSA_CHECK(i != nullptr && i->components == 1, "a tunable material parameter that is not a registry scalar");
    return *i;
}

bool valid(const reflectance::MapParams& p) {
    try {
        reflectance::validate(p);
        return true;
    } catch (const InputError&) {
        return false;
    }
}

// A tileable map's octaves must each repeat across the map: f * lacunarity^i
// whole and at most 256 or a multiple of 256 (noise::validate). A frequency
// the lattice refuses (12 with 6 octaves: 384 cycles in the last) moves to the
// nearest one it accepts (8 or 16), the lower one on a tie.
void nearestTileableFrequency(reflectance::MapParams& p) {
    if (!p.noise.tileable || valid(p)) return;
    const double f = p.noise.frequency;
    for (int d = 1; d <= 256; ++d)
        for (int sgn : {-1, +1}) {
            reflectance::MapParams q = p;
            q.noise.frequency = f + sgn * d;
            if (q.noise.frequency > 0 && valid(q)) {
                p = q;
                return;
            }
        }
}

}  // namespace

double fromUnit(const TuneParam& p, double t) {
    t = std::clamp(t, 0.0, 1.0);
    const double v =
        p.logScale ? std::exp(std::log(p.min) + t * (std::log(p.max) - std::log(p.min))) : p.min + t * (p.max - p.min);
    return p.integer ? std::round(v) : v;
}
double toUnit(const TuneParam& p, double v) {
    v = std::clamp(v, p.min, p.max);
    return p.logScale ? (std::log(v) - std::log(p.min)) / (std::log(p.max) - std::log(p.min))
                      : (v - p.min) / (p.max - p.min);
}

std::span<const TuneParam> tuneParams() noexcept {
    return kTuneParams;
}

std::vector<std::string> defaultTuneKeys() {
    std::vector<std::string> keys;
    for (std::size_t i = 0; i < kDefaultTuneCount; ++i) keys.emplace_back(kTuneParams[i].key);
    return keys;
}

const TuneParam& findTuneParam(std::string_view key, const std::string& subject) {
    std::string known;
    for (const TuneParam& p : kTuneParams) {
        // The key alone ("shininess") or with its group ("material.shininess").
        if (p.key == key || p.key.substr(p.key.find('.') + 1) == key) return p;
        known += (known.empty() ? "" : ", ") + std::string(p.key);
    }
    // The nearest key by prefix or suffix match, for a typo's hint.
    std::string hint;
    for (const TuneParam& p : kTuneParams) {
        const std::string_view name = p.key.substr(p.key.find('.') + 1);
        if (!key.empty() && (name.starts_with(key.substr(0, std::min<std::size_t>(key.size(), 4))))) {
            hint = fmt::format("did you mean '{}'? ", p.key);
            break;
        }
    }
    throw InputError(subject, "", fmt::format("unknown parameter '{}' ({}known: {})", key, hint, known));
}

double tuneValue(const scene::Scene& scene, const TuneParam& p) {
    if (isMap(p)) return reflectance::get(scene.mapParams, mapInfo(p).id);
    if (isTissue(p)) return scene::tissueParams(scene).*(tissueInfo(p).member);
    return scene.params[materialInfo(p).id];
}

void setTuneValue(scene::Scene& scene, const TuneParam& p, double value) {
    const std::string subject(p.key);
    if (!std::isfinite(value)) throw InputError(subject, "", "must be finite");
    if (p.integer) value = std::round(value);
    if (isMap(p)) {
        const reflectance::MapParamInfo& i = mapInfo(p);
        const json v = i.kind == reflectance::MapParamKind::Integer ? json(static_cast<long long>(value)) : json(value);
        reflectance::set(scene.mapParams, i.id, v, subject);
        nearestTileableFrequency(scene.mapParams);
        scene.reflectanceMap.reset();  // generated from the parameters, as --set reflectance_map does
        scene.mapParams.preset.clear();
        return;
    }
    if (isTissue(p)) {
        scene::setTissueParameter(scene, std::string(tissueInfo(p).name), value, subject);
        return;
    }
    scene.params.set(materialInfo(p).id, static_cast<float>(value), "", subject);
}

std::vector<double> appliedValues(const scene::Scene& scene, const std::vector<const TuneParam*>& params,
                                  const std::vector<double>& unit) {
    scene::Scene c = scene;
    for (std::size_t i = 0; i < params.size(); ++i) setTuneValue(c, *params[i], fromUnit(*params[i], unit[i]));
    std::vector<double> v(params.size());
    for (std::size_t i = 0; i < params.size(); ++i) v[i] = tuneValue(c, *params[i]);
    return v;
}

// ------------------------------------------------------------------ probe

namespace {

// The generated texture's parameters, to tell when it must be made again
// (empty when the scene's texture is not generated).
std::vector<double> tissueKey(const scene::Scene& s) {
    if (!s.generatedDiffuse || s.diffuse) return {};
    const reflectance::TissueParams t = scene::tissueParams(s);
    std::vector<double> k = {static_cast<double>(t.seed)};
    for (const reflectance::TissueParamInfo& i : reflectance::tissueRegistry()) k.push_back(t.*i.member);
    return k;
}

// What the scene's map is made from: "file", or the generation parameters
// (without the preset's name, which is informational).
json mapKey(const scene::Scene& s) {
    if (s.reflectanceMap) return "file";
    json j = reflectance::toJson(s.mapParams);
    j.erase("preset");
    return j;
}

}  // namespace

struct HighlightProbe::Impl {
    // The scene, then each patient drawn from it: the scene itself, its
    // views, and its own generated texture.
    struct Base {
        scene::Scene scene;
        std::vector<camera::Pose> poses;
        std::vector<double> tissue;  // tissueKey
        image::Image8 texture;
    };
    std::vector<Base> bases;
    scene::Scene current;  // the session reads this one (by reference)
    scene::SceneAssets assets;
    std::unique_ptr<render::OffscreenSession> session;
    json mapOfBase;                       // the parameters of assets.reflectanceMap ("file": the scene's map file)
    json mapOfSession;                    // those of the map the session shows
    std::vector<double> tissueOfSession;  // the generated texture's (tissueKey)
    std::vector<image::Image8> frames;
    int threads = 0;
    bool asLook = false;

    // The base scene with `values` applied.
    scene::Scene with(const scene::Scene& base, const TuneValues& values) const {
        scene::Scene s = base;
        if (!asLook) {
            for (const auto& [p, v] : values) setTuneValue(s, *p, v);
            return s;
        }
        // The map's parameters as they are; the rest as a look's centre.
        scene::Scene::Look look = s.look;
        for (const auto& [p, v] : values) {
            if (isMap(*p)) {
                setTuneValue(s, *p, v);
            } else if (isTissue(*p)) {
                look.tissue[std::string(tissueInfo(*p).name)] = v;
            } else {
                const shading::Param id = materialInfo(*p).id;
                std::erase_if(look.params, [id](const auto& q) { return q.first == id; });
                look.params.push_back({id, static_cast<float>(v)});
            }
        }
        scene::applyLook(s, look);
        return s;
    }
};

HighlightProbe::HighlightProbe(const scene::Scene& base, const ProbeOptions& o) : impl_(std::make_unique<Impl>()) {
    if (o.views < 1) throw InputError("--views", "", fmt::format("must be at least 1, got {}", o.views));
    if (o.size < 16) throw InputError("--size", "", fmt::format("must be at least 16, got {}", o.size));
    if (o.patients < 0 || o.patients > 64)
        throw InputError("--patients", "", fmt::format("must be in 0..64, got {}", o.patients));
    Impl& m = *impl_;
    m.threads = o.threads;
    m.asLook = o.asLook;
    scene::Scene first = base;
    first.width = first.height = o.size;
    if (first.mode != shading::Mode::Noise && first.mode != shading::Mode::Procedural &&
        first.mode != shading::Mode::BrdfNoise)
        throw InputError("--mode", "",
                         fmt::format("tuning needs a mode that reads the map's noise (noise, procedural, "
                                     "brdf-noise), not {}",
                                     shading::modeName(first.mode)));
    m.current = first;
    m.assets = scene::loadAssets(first, o.threads, shading::info(first.mode).readsMap);
    m.mapOfBase = mapKey(first);
    m.mapOfSession = m.mapOfBase;
    for (int k = 0; k <= o.patients; ++k) {
        Impl::Base b;
        b.scene = first;
        if (k > 0) {
            scene::applyVariation(b.scene, static_cast<std::uint64_t>(k));
            b.scene.path.fly.seed = static_cast<std::uint64_t>(k);
        }
        b.poses = scene::cameraPoses(b.scene, m.assets, o.views);
        b.tissue = tissueKey(b.scene);
        if (k == 0)
            b.texture = m.assets.diffuse;
        else if (!b.tissue.empty())
            b.texture = reflectance::tissueTexture(scene::tissueParams(b.scene), m.assets.diffuse.width());
        m.bases.push_back(std::move(b));
    }
    m.tissueOfSession = m.bases.front().tissue;
    m.session = std::make_unique<render::OffscreenSession>(m.current, m.assets, o.size, o.size);
}

HighlightProbe::~HighlightProbe() = default;

std::vector<FrameHighlights> HighlightProbe::measure(const TuneValues& values) {
    std::vector<FrameHighlights> out;
    for (const image::Image8& f : renderViews(values)) out.push_back(measureHighlights(f));
    return out;
}

const std::vector<image::Image8>& HighlightProbe::renderViews(const TuneValues& values) {
    Impl& m = *impl_;
    m.frames.clear();
    for (const Impl::Base& b : m.bases) {
        m.current = m.with(b.scene, values);  // assigned in place: the session keeps its reference
        if (shading::info(m.current.mode).readsMap) {
            // The map the session shows: the scene's (a file, or generated by
            // loadAssets) while the map parameters are the scene's, else one
            // generated as scene::loadAssets generates it.
            const json now = mapKey(m.current);
            if (now != m.mapOfSession) {
                if (now == m.mapOfBase) {
                    m.session->setReflectanceMap(m.assets.reflectanceMap);
                } else {
                    const image::ImageF h = reflectance::heightField(m.current.mapParams, m.threads);
                    m.session->setReflectanceMap(reflectance::encodeNormals8(
                        h, m.current.mapParams.strength,
                        m.current.mapParams.noise.tileable ? reflectance::Edges::Wrap : reflectance::Edges::Clamp,
                        m.threads));
                }
                m.mapOfSession = now;
            }
        }
        if (const std::vector<double> now = tissueKey(m.current); now != m.tissueOfSession) {
            m.session->setDiffuse(
                now == b.tissue ? b.texture
                                : reflectance::tissueTexture(scene::tissueParams(m.current), m.assets.diffuse.width()));
            m.tissueOfSession = now;
        }
        for (const camera::Pose& pose : b.poses) m.frames.push_back(m.session->render(pose));
    }
    return m.frames;
}

const std::vector<image::Image8>& HighlightProbe::lastFrames() const noexcept {
    return impl_->frames;
}

const scene::Scene& HighlightProbe::base() const noexcept {
    return impl_->bases.front().scene;
}

std::string HighlightProbe::glRenderer() const {
    return impl_->session->glRendererName();
}

// ------------------------------------------------------------------ sweep

std::vector<double> sweepValues(const TuneParam& p, int steps, double base) {
    std::vector<double> v;
    for (int i = 0; i < steps; ++i) v.push_back(fromUnit(p, steps == 1 ? 0.5 : static_cast<double>(i) / (steps - 1)));
    v.push_back(p.integer ? std::round(base) : base);
    std::sort(v.begin(), v.end());
    // Distinct: integers rounded to the same value, or the base on a step.
    v.erase(std::unique(v.begin(), v.end(), [](double a, double b) { return std::abs(a - b) <= 1e-9 * std::abs(b); }),
            v.end());
    return v;
}

SweepResult sweep(const scene::Scene& scene, const SweepOptions& o) {
    if (o.steps < 2) throw InputError("--steps", "", fmt::format("must be at least 2, got {}", o.steps));
    SweepResult r;
    for (const std::string& k : o.params.empty() ? defaultTuneKeys() : o.params) r.params.push_back(&findTuneParam(k));
    HighlightProbe probe(scene, o.probe);
    r.views = o.probe.views;
    r.size = o.probe.size;
    std::vector<std::vector<double>> values;
    int total = 0;
    for (const TuneParam* p : r.params) {
        r.baseValues.push_back(tuneValue(probe.base(), *p));
        // The values as set (a tileable map's frequency moves to one its lattice takes), distinct.
        std::vector<double> v;
        for (double x : sweepValues(*p, o.steps, r.baseValues.back())) {
            scene::Scene c = probe.base();
            setTuneValue(c, *p, x);
            v.push_back(tuneValue(c, *p));
        }
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end()), v.end());
        values.push_back(v);
        total += static_cast<int>(values.back().size());
    }
    // The scene's own values are measured once and shared by every parameter's row.
    std::vector<FrameHighlights> baseViews;
    int done = 0;
    for (std::size_t i = 0; i < r.params.size(); ++i) {
        for (double v : values[i]) {
            SweepPoint pt;
            pt.param = r.params[i];
            pt.value = v;
            const double base = r.params[i]->integer ? std::round(r.baseValues[i]) : r.baseValues[i];
            pt.isBase = std::abs(v - base) <= 1e-9 * std::abs(base);
            if (pt.isBase && !baseViews.empty()) {
                pt.views = baseViews;
            } else {
                pt.views = probe.measure({{r.params[i], v}});
                if (pt.isBase) baseViews = pt.views;
            }
            pt.summary = summarise(pt.views);
            r.points.push_back(std::move(pt));
            if (o.progress) o.progress(++done, total);
        }
    }
    return r;
}

namespace {

json number(double v) {
    return std::isfinite(v) ? json(v) : json(nullptr);
}

json summaryJson(const HighlightSummary& s) {
    json j = json::object();
    for (int k = 0; k < kHighlightStatCount; ++k) {
        const StatSummary& st = s.stats[static_cast<std::size_t>(k)];
        j[std::string(statName(static_cast<HighlightStat>(k)))] = {
            {"median", number(st.median)}, {"q1", number(st.q1)}, {"q3", number(st.q3)}, {"n", st.n}};
    }
    return j;
}

std::string fmtValue(double v) {
    return std::isfinite(v) ? fmt::format("{:.6g}", v) : "nan";
}

}  // namespace

std::string sweepTsv(const SweepResult& r) {
    std::string s = "param\tvalue\tbase";
    for (int k = 0; k < kHighlightStatCount; ++k) {
        const std::string_view n = statName(static_cast<HighlightStat>(k));
        s += fmt::format("\t{0}_median\t{0}_q1\t{0}_q3", n);
    }
    s += "\n";
    for (const SweepPoint& p : r.points) {
        s += fmt::format("{}\t{}\t{}", p.param->key, fmtValue(p.value), p.isBase ? 1 : 0);
        for (const StatSummary& st : p.summary.stats)
            s += fmt::format("\t{}\t{}\t{}", fmtValue(st.median), fmtValue(st.q1), fmtValue(st.q3));
        s += "\n";
    }
    return s;
}

std::string sweepJson(const SweepResult& r, const HighlightSummary* target) {
    json j;
    j["about"] =
        "mucosa tune sweep: highlight statistics (realism_stats.py definitions) per parameter value, "
        "median and quartiles over the views";
    j["views"] = r.views;
    j["size"] = r.size;
    json params = json::array();
    for (std::size_t i = 0; i < r.params.size(); ++i) {
        json pts = json::array();
        for (const SweepPoint& p : r.points) {
            if (p.param != r.params[i]) continue;
            json views = json::array();
            for (const FrameHighlights& f : p.views) {
                json v = json::object();
                for (int k = 0; k < kHighlightStatCount; ++k)
                    v[std::string(statName(static_cast<HighlightStat>(k)))] =
                        number(f.values[static_cast<std::size_t>(k)]);
                views.push_back(v);
            }
            pts.push_back(
                {{"value", p.value}, {"base", p.isBase}, {"summary", summaryJson(p.summary)}, {"views", views}});
        }
        params.push_back({{"param", std::string(r.params[i]->key)},
                          {"base_value", r.baseValues[i]},
                          {"min", r.params[i]->min},
                          {"max", r.params[i]->max},
                          {"log_scale", r.params[i]->logScale},
                          {"points", pts}});
    }
    j["params"] = params;
    if (target != nullptr) j["target"] = summaryJson(*target);
    return j.dump(1) + "\n";
}

namespace {

// A "nice" tick label: 3 significant digits, no trailing zeros.
std::string tickLabel(double v) {
    return fmt::format("{:.3g}", v);
}

}  // namespace

std::string sweepSvg(const SweepResult& r, HighlightStat stat, const HighlightSummary* target) {
    const std::size_t k = static_cast<std::size_t>(stat);
    const int np = static_cast<int>(r.params.size());
    const int cols = std::min(np, 3), rows = (np + cols - 1) / std::max(cols, 1);
    constexpr int kPw = 240, kPh = 170, kMl = 52, kMr = 12, kMt = 26, kMb = 34, kTop = 44;
    const int W = cols * (kPw + kMl + kMr), H = kTop + rows * (kPh + kMt + kMb) + 8;
    // Each panel its own y range (the medians, the quartiles and the target
    // band): the specular parameters move the counts by orders of magnitude
    // more than the map's, and one shared range would flatten the map's panels.
    auto yRange = [&](const TuneParam* p) {
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        auto take = [&](double v) {
            if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
        };
        for (const SweepPoint& pt : r.points)
            if (pt.param == p)
                take(pt.summary.stats[k].q1), take(pt.summary.stats[k].q3), take(pt.summary.stats[k].median);
        if (target != nullptr && target->stats[k].n > 0) take(target->stats[k].q1), take(target->stats[k].q3);
        if (!std::isfinite(lo)) lo = 0, hi = 1;
        if (lo >= 0 && lo < 0.25 * hi) lo = 0;  // from zero when the data nearly reach it
        if (hi - lo < 1e-12) hi = lo + std::max(1.0, std::abs(lo));
        const double pad = 0.05 * (hi - lo);
        return std::pair{lo == 0 ? 0.0 : lo - pad, hi + pad};
    };

    std::string s = fmt::format(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
        "font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"{0}\" height=\"{1}\" fill=\"white\"/>\n"
        "<text x=\"8\" y=\"18\" font-size=\"14\" font-weight=\"bold\">{2}: {3}</text>\n"
        "<text x=\"8\" y=\"34\" fill=\"#555\">median over {4} views (line), interquartile range (shaded), scene's "
        "value (dashed, red){5}; each panel its own y scale</text>\n",
        W, H, statName(stat), escapeXml(statMeaning(stat)), r.views,
        target != nullptr ? "; target median and IQR (green)" : "");
    for (int i = 0; i < np; ++i) {
        const TuneParam& p = *r.params[static_cast<std::size_t>(i)];
        const int x0 = (i % cols) * (kPw + kMl + kMr) + kMl, y0 = kTop + (i / cols) * (kPh + kMt + kMb) + kMt;
        const std::pair<double, double> range = yRange(&p);
        const double lo = range.first, hi = range.second;
        auto X = [&](double v) { return x0 + kPw * toUnit(p, v); };
        auto Y = [&](double v) { return y0 + kPh * (1.0 - (v - lo) / (hi - lo)); };
        s += fmt::format("<g>\n<text x=\"{}\" y=\"{}\" font-weight=\"bold\">{}</text>\n", x0, y0 - 8, escapeXml(p.key));
        s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"#fafafa\" stroke=\"#999\"/>\n", x0,
                         y0, kPw, kPh);
        if (target != nullptr && target->stats[k].n > 0) {
            const StatSummary& t = target->stats[k];
            s += fmt::format(
                "<rect x=\"{}\" y=\"{:.1f}\" width=\"{}\" height=\"{:.1f}\" fill=\"#2a2\" "
                "fill-opacity=\"0.15\"/>\n<line x1=\"{}\" x2=\"{}\" y1=\"{:.1f}\" y2=\"{:.1f}\" "
                "stroke=\"#2a2\" stroke-width=\"1.5\"/>\n",
                x0, Y(t.q3), kPw, std::max(0.5, Y(t.q1) - Y(t.q3)), x0, x0 + kPw, Y(t.median), Y(t.median));
        }
        // y ticks: 5 values.
        for (int t = 0; t <= 4; ++t) {
            const double v = lo + (hi - lo) * t / 4.0;
            s += fmt::format(
                "<line x1=\"{}\" x2=\"{}\" y1=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"#ddd\"/>"
                "<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\" fill=\"#333\">{}</text>\n",
                x0, x0 + kPw, Y(v), Y(v), x0 - 4, Y(v) + 4, tickLabel(v));
        }
        // x ticks: the swept values (at most 8 labelled).
        std::vector<const SweepPoint*> pts;
        for (const SweepPoint& pt : r.points)
            if (pt.param == &p) pts.push_back(&pt);
        const std::size_t every = std::max<std::size_t>(1, (pts.size() + 7) / 8);
        double baseX = -1e9;
        for (const SweepPoint* pt : pts)
            if (pt->isBase) baseX = X(pt->value);
        for (std::size_t j = 0; j < pts.size(); ++j) {
            const double x = X(pts[j]->value);
            s += fmt::format("<line x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2}\" stroke=\"#333\"/>\n", x,
                             y0 + kPh, y0 + kPh + 4);
            // Every few values labelled, and the scene's, whose label no neighbour overlaps.
            if (pts[j]->isBase || (j % every == 0 && std::abs(x - baseX) > 34))
                s += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\" fill=\"{}\">{}</text>\n", x,
                                 y0 + kPh + 16, pts[j]->isBase ? "#c00" : "#333", tickLabel(pts[j]->value));
        }
        s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" fill=\"#555\">{}{}</text>\n", x0 + kPw / 2,
                         y0 + kPh + 30, escapeXml(p.label), p.logScale ? " (log)" : "");
        const SweepPoint* base = nullptr;
        for (const SweepPoint* pt : pts)
            if (pt->isBase) base = pt;
        if (base != nullptr)
            s += fmt::format(
                "<line x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2}\" stroke=\"#c00\" "
                "stroke-dasharray=\"4 3\"/>\n",
                X(base->value), y0, y0 + kPh);
        // The IQR band and the median line, over the values that have one.
        std::string band, upper, lower, line;
        for (const SweepPoint* pt : pts) {
            const StatSummary& st = pt->summary.stats[k];
            if (st.n == 0) continue;
            upper += fmt::format("{:.1f},{:.1f} ", X(pt->value), Y(st.q3));
            lower = fmt::format("{:.1f},{:.1f} ", X(pt->value), Y(st.q1)) + lower;
            line += fmt::format("{:.1f},{:.1f} ", X(pt->value), Y(st.median));
        }
        if (!upper.empty())
            s += fmt::format("<polygon points=\"{}{}\" fill=\"#36c\" fill-opacity=\"0.2\" stroke=\"none\"/>\n", upper,
                             lower);
        if (!line.empty())
            s += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"#036\" stroke-width=\"2\"/>\n", line);
        for (const SweepPoint* pt : pts)
            if (pt->summary.stats[k].n > 0)
                s += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.5\" fill=\"#036\"/>\n", X(pt->value),
                                 Y(pt->summary.stats[k].median));
        s += "</g>\n";
    }
    s += "</svg>\n";
    return s;
}

// ------------------------------------------------------------------ fit

TuneFitResult fitToTarget(const scene::Scene& scene, const HighlightSummary& target, const TuneFitOptions& o) {
    std::vector<const TuneParam*> params;
    for (const std::string& k : o.params.empty() ? defaultTuneKeys() : o.params) {
        const TuneParam* p = &findTuneParam(k);
        if (std::find(params.begin(), params.end(), p) != params.end())
            throw InputError("--params", "", fmt::format("'{}' is given twice", p->key));
        params.push_back(p);
    }
    std::vector<HighlightStat> stats = o.stats;
    if (stats.empty())
        for (int k = 0; k < kHighlightStatCount; ++k) stats.push_back(static_cast<HighlightStat>(k));
    int usable = 0;
    for (HighlightStat s : stats) usable += target[s].n > 0;
    if (usable == 0) throw InputError("target", "", "has none of the highlight statistics to fit");
    if (o.maxEvaluations < 1)
        throw InputError("--max-evals", "", fmt::format("must be at least 1, got {}", o.maxEvaluations));

    HighlightProbe probe(scene, o.probe);
    const std::size_t d = params.size();
    std::vector<double> t(d);
    TuneFitResult r;
    for (std::size_t i = 0; i < d; ++i) {
        const double v = tuneValue(probe.base(), *params[i]);
        r.start.push_back({params[i], v});
        t[i] = toUnit(*params[i], v);
    }
    // Evaluations are cached by the values applied (integers rounded), so a
    // step that rounds to the same setting costs no render.
    std::map<std::vector<double>, std::pair<double, HighlightSummary>> cache;
    auto applied = [&](const std::vector<double>& u) { return appliedValues(probe.base(), params, u); };
    double bestSoFar = std::numeric_limits<double>::infinity();
    auto evaluate = [&](const std::vector<double>& u, bool first) -> std::pair<double, HighlightSummary> {
        // The first evaluation is at the scene's own values, unrounded.
        std::vector<double> v = first ? std::vector<double>() : applied(u);
        if (first)
            for (const auto& [p, x] : r.start) v.push_back(p->integer ? std::round(x) : x);
        if (auto it = cache.find(v); it != cache.end()) return it->second;
        TuneValues values;
        for (std::size_t i = 0; i < d; ++i) values.push_back({params[i], v[i]});
        const HighlightSummary s = summarise(probe.measure(values));
        const double dist = distance(s, target, stats).total;
        ++r.evaluations;
        cache[v] = {dist, s};
        bestSoFar = std::min(bestSoFar, dist);
        if (o.progress) o.progress(r.evaluations, o.maxEvaluations, bestSoFar);
        return cache[v];
    };
    auto [best, bestSummary] = evaluate(t, true);
    r.before = distance(bestSummary, target, stats);
    r.beforeSummary = bestSummary;
    detail::patternSearch(
        t, best, [&](const std::vector<double>& u) { return evaluate(u, false).first; },
        [&] { return r.evaluations < o.maxEvaluations; }, o.tolerance);
    // The best point's summary: the start's unless the search improved on it.
    if (best < r.before.total - 1e-12) bestSummary = cache.at(applied(t)).second;
    r.afterSummary = bestSummary;
    r.after = distance(bestSummary, target, stats);
    // The best point's values: the start (unrounded) if nothing improved on it.
    if (r.after.total < r.before.total - 1e-12) {
        const std::vector<double> v = applied(t);
        for (std::size_t i = 0; i < d; ++i) r.best.push_back({params[i], v[i]});
    } else {
        r.best = r.start;
        r.after = r.before;
        r.afterSummary = r.beforeSummary;
    }
    return r;
}

std::string presetJson(const scene::Scene& scene, const TuneValues& values, bool everyMapKey) {
    scene::Scene s = scene;
    for (const auto& [p, v] : values) setTuneValue(s, *p, v);
    json map = json::object();
    const reflectance::MapParams& mp = s.mapParams;
    for (const reflectance::MapParamInfo& i : reflectance::mapRegistry()) {
        if (i.id == reflectance::MapParam::Bits) continue;  // a file format choice, not the look
        switch (i.kind) {
            case reflectance::MapParamKind::Boolean:
                map[std::string(i.name)] = reflectance::get(mp, i.id) != 0;
                break;
            case reflectance::MapParamKind::Seed:
                map[std::string(i.name)] = mp.noise.seed;
                break;
            case reflectance::MapParamKind::Integer:
                map[std::string(i.name)] = static_cast<long long>(reflectance::get(mp, i.id));
                break;
            case reflectance::MapParamKind::Real:
                map[std::string(i.name)] = reflectance::get(mp, i.id);
                break;
        }
    }
    json j = everyMapKey ? json{{"reflectance_map", map}} : json::object();
    for (const auto& [p, v] : values) {
        if (isMap(*p)) {
            // Only the keys fitted: the map keeps the scene's other parameters.
            if (!everyMapKey) j["reflectance_map"][std::string(mapInfo(*p).name)] = map[std::string(mapInfo(*p).name)];
            continue;
        }
        if (isTissue(*p)) {
            // Six significant digits: a fitted value, not a measured one.
            j["tissue"][std::string(tissueInfo(*p).name)] = std::stod(fmt::format("{:.6g}", tuneValue(s, *p)));
            continue;
        }
        // The float as its shortest decimal (0.22, not 0.2199999988).
        const shading::ParamInfo& i = materialInfo(*p);
        j[std::string(i.group)][std::string(i.name)] = std::stod(fmt::format("{}", s.params[i.id]));
    }
    return j.dump(2) + "\n";
}

}  // namespace mucosa::tune
