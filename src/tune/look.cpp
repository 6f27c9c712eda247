#include <mucosa/tune/look.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/scene/scene.hpp>

#include "pattern_search.hpp"

namespace mucosa::tune {

namespace {

using LG = LookGroup;
// Searched in this order: the large-scale appearance first (exposure and
// colour), the fine detail last.
constexpr std::array<LookParam, 19> kLookParams = {{
    {"camera.auto_key", LG::Exposure},
    {"camera.vignetting", LG::Exposure},
    {"light.spread", LG::Exposure},
    {"camera.flare", LG::Exposure},
    {"tissue.lightness", LG::Colour},
    {"tissue.chroma", LG::Colour},
    {"tissue.hue", LG::Colour},
    {"tissue.hue_variation", LG::Colour},
    {"camera.saturation", LG::Colour},
    {"tissue.mottle", LG::Texture},
    {"tissue.vessel_density", LG::Texture},
    {"tissue.vessel_contrast", LG::Texture},
    {"material.mucus_opacity", LG::Mucus},
    {"material.sheen", LG::Mucus},
    {"material.specular_strength", LG::Highlights},
    {"material.shininess", LG::Highlights},
    {"camera.softness_px", LG::Camera},
    {"camera.read_noise", LG::Camera},
    {"camera.full_well", LG::Camera},
}};

}  // namespace

std::string_view lookGroupName(LookGroup g) noexcept {
    switch (g) {
        case LG::Colour:
            return "colour";
        case LG::Texture:
            return "texture";
        case LG::Mucus:
            return "mucus";
        case LG::Highlights:
            return "highlights";
        case LG::Exposure:
            return "exposure";
        case LG::Camera:
            return "camera";
    }
    return "";
}

std::span<const LookParam> lookParams() noexcept {
    return kLookParams;
}

LookGroup lookGroup(const TuneParam& p) noexcept {
    for (const LookParam& l : kLookParams)
        if (l.key == p.key) return l.group;
    return LG::Highlights;
}

LookEvaluation evaluateLook(const std::vector<FrameStats>& target, const FrameStatsSummary& targetSummary,
                            const std::vector<FrameStats>& ours, double observerWeight, int observerGroups) {
    LookEvaluation e;
    e.summary = summarise(ours);
    e.realism = realismScore(e.summary, targetSummary);
    e.auc = logisticObserver(target, ours, observerGroups).auc;
    e.objective = e.realism.overall + observerWeight * (e.auc - 0.5);
    return e;
}

LookFitResult fitLook(const scene::Scene& scene, const std::vector<FrameStats>& target, const LookFitOptions& o) {
    if (target.size() < 2)
        throw InputError("frames", "", fmt::format("needs at least 2 real frames to fit to, got {}", target.size()));
    if (o.maxEvaluations < 1)
        throw InputError("--max-evals", "", fmt::format("must be at least 1, got {}", o.maxEvaluations));
    if (o.probe.views < 2) throw InputError("--views", "", fmt::format("must be at least 2, got {}", o.probe.views));
    if (!(o.observerWeight >= 0))
        throw InputError("--observer-weight", "", fmt::format("must be at least 0, got {}", o.observerWeight));
    std::vector<const TuneParam*> params;
    std::vector<std::string> keys = o.params;
    if (keys.empty())
        for (const LookParam& l : kLookParams) keys.emplace_back(l.key);
    for (const std::string& k : keys) {
        const TuneParam* p = &findTuneParam(k);
        if (std::find(params.begin(), params.end(), p) != params.end())
            throw InputError("--params", "", fmt::format("'{}' is given twice", p->key));
        params.push_back(p);
    }
    const FrameStatsSummary targetSummary = summarise(target);

    ProbeOptions po = o.probe;
    po.asLook = true;  // the values are the centre the patients vary about, as --look applies them
    HighlightProbe probe(scene, po);
    const std::size_t d = params.size();
    LookFitResult r;
    std::vector<double> t(d);
    // The start: the scene's centre — its own values and look without its
    // patient's draw, which the probe draws again about every trial look.
    scene::Scene centre = probe.base();
    if (centre.variation != 0) scene::applyVariation(centre, 0);
    for (std::size_t i = 0; i < d; ++i) {
        const double v = tuneValue(centre, *params[i]);
        r.start.push_back({params[i], v});
        t[i] = toUnit(*params[i], v);
    }
    auto applied = [&](const std::vector<double>& u) { return appliedValues(probe.base(), params, u); };
    std::map<std::vector<double>, LookEvaluation> cache;
    double bestSoFar = std::numeric_limits<double>::infinity();
    auto evaluate = [&](const std::vector<double>& v) -> const LookEvaluation& {
        if (auto it = cache.find(v); it != cache.end()) return it->second;
        TuneValues values;
        for (std::size_t i = 0; i < d; ++i) values.push_back({params[i], v[i]});
        std::vector<FrameStats> ours;
        for (const image::Image8& f : probe.renderViews(values)) ours.push_back(measureFrame(f));
        ++r.evaluations;
        const LookEvaluation& e =
            cache.emplace(v, evaluateLook(target, targetSummary, ours, o.observerWeight, o.observerGroups))
                .first->second;
        bestSoFar = std::min(bestSoFar, e.objective);
        if (o.progress) o.progress(r.evaluations, o.maxEvaluations, bestSoFar);
        return e;
    };
    // The start: the scene's own values, unrounded.
    std::vector<double> startValues;
    for (const auto& [p, x] : r.start) startValues.push_back(p->integer ? std::round(x) : x);
    r.before = evaluate(startValues);
    double best = r.before.objective;
    detail::patternSearch(
        t, best, [&](const std::vector<double>& u) { return evaluate(applied(u)).objective; },
        [&] { return r.evaluations < o.maxEvaluations; }, o.tolerance);
    if (best < r.before.objective - 1e-12) {
        const std::vector<double> v = applied(t);
        r.after = cache.at(v);
        for (std::size_t i = 0; i < d; ++i) r.best.push_back({params[i], v[i]});
        TuneValues values = r.best;
        r.frames = probe.renderViews(values);
    } else {
        r.best = r.start;
        r.after = r.before;
        r.frames = probe.renderViews(r.start);
    }
    return r;
}

}  // namespace mucosa::tune
