// mucosa tune (tune/tune.hpp): the tunable parameters, the sweep's values and
// plots, the preset round trip, parameter recovery with the render in the
// loop, and the command's errors.
#include <mucosa/tune/tune.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/scene/scene.hpp>
#include <mucosa/shading/params.hpp>

#include "test_support.hpp"

namespace {

using namespace mucosa;
using tune::HighlightStat;

TEST(Tune, ParametersAreFoundByKeyOrNameAndRefusedWithAHint) {
    EXPECT_EQ(tune::findTuneParam("material.shininess").key, "material.shininess");
    EXPECT_EQ(tune::findTuneParam("shininess").key, "material.shininess");
    EXPECT_EQ(tune::findTuneParam("frequency").key, "reflectance_map.frequency");
    try {
        tune::findTuneParam("shinyness");
        FAIL() << "an unknown parameter was accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "--params");
        EXPECT_NE(std::string(e.reason()).find("did you mean 'material.shininess'"), std::string::npos) << e.reason();
    }
    EXPECT_EQ(tune::defaultTuneKeys().size(), 6u);
    // Every range lies inside the registry's: its ends can be set.
    for (const tune::TuneParam& p : tune::tuneParams()) {
        scene::Scene s = scene::defaultScene();
        EXPECT_NO_THROW(tune::setTuneValue(s, p, p.min)) << p.key;
        EXPECT_NEAR(tune::tuneValue(s, p), p.integer ? std::round(p.min) : p.min, 1e-6 * p.min) << p.key;
        EXPECT_NO_THROW(tune::setTuneValue(s, p, p.max)) << p.key;
    }
}

TEST(Tune, ValuesAreRoundedAndCheckedAgainstTheRegistry) {
    scene::Scene s = scene::defaultScene();
    tune::setTuneValue(s, tune::findTuneParam("octaves"), 3.6);
    EXPECT_EQ(s.mapParams.noise.octaves, 4);
    tune::setTuneValue(s, tune::findTuneParam("frequency"), 23.4);  // a tileable map needs whole cycles
    EXPECT_EQ(s.mapParams.noise.frequency, 23.0);
    // With 6 octaves, 24 cycles would put 384 in the last (a tileable period
    // above 256 must be a multiple of it): the nearest the lattice takes, the lower on a tie.
    tune::setTuneValue(s, tune::findTuneParam("octaves"), 6);
    tune::setTuneValue(s, tune::findTuneParam("frequency"), 24);
    EXPECT_EQ(s.mapParams.noise.frequency, 16.0);
    tune::setTuneValue(s, tune::findTuneParam("frequency"), 7);
    EXPECT_EQ(s.mapParams.noise.frequency, 7.0);
    tune::setTuneValue(s, tune::findTuneParam("specular_strength"), 1.5);
    EXPECT_FLOAT_EQ(s.params[shading::Param::SpecularStrength], 1.5f);
    EXPECT_THROW(tune::setTuneValue(s, tune::findTuneParam("shininess"), 1e6), InputError);
    EXPECT_THROW(tune::setTuneValue(s, tune::findTuneParam("gain"), NAN), InputError);
}

TEST(Tune, SweepValuesSpanTheRangeAndIncludeTheScenesValue) {
    const tune::TuneParam& f = tune::findTuneParam("frequency");
    const std::vector<double> v = tune::sweepValues(f, 7, 16);
    // 2 .. 128 in equal ratios (x2), rounded; 16 is one of them.
    EXPECT_EQ(v, (std::vector<double>{2, 4, 8, 16, 32, 64, 128}));
    const std::vector<double> g = tune::sweepValues(tune::findTuneParam("gain"), 4, 0.5);
    EXPECT_EQ(g.size(), 5u);
    EXPECT_DOUBLE_EQ(g[0], 0.2);
    EXPECT_DOUBLE_EQ(g[2], 0.5);  // the scene's value, inserted in order
    EXPECT_DOUBLE_EQ(g[4], 0.8);
    EXPECT_TRUE(std::is_sorted(g.begin(), g.end()));
    const std::vector<double> o = tune::sweepValues(tune::findTuneParam("octaves"), 20, 6);
    EXPECT_EQ(o, (std::vector<double>{1, 2, 3, 4, 5, 6, 7, 8}));  // distinct whole numbers
}

TEST(Tune, PresetJsonIsASceneWithTheFittedLook) {
    test::TempDir dir;
    const scene::Scene base = scene::defaultScene();
    const tune::TuneValues v = {{&tune::findTuneParam("frequency"), 32},
                                {&tune::findTuneParam("strength"), 0.012},
                                {&tune::findTuneParam("shininess"), 90}};
    // A fragment: with a mesh it is a whole scene.
    nlohmann::json j = nlohmann::json::parse(tune::presetJson(base, v));
    EXPECT_EQ(j.size(), 2u);  // reflectance_map and material, nothing else
    j["mesh"] = "phantom";
    writeFileAtomic(dir / "preset.json", j.dump());
    const scene::Scene s = scene::loadScene(dir / "preset.json");
    EXPECT_EQ(s.mapParams.noise.frequency, 32);
    EXPECT_DOUBLE_EQ(s.mapParams.strength, 0.012);
    EXPECT_EQ(s.mapParams.noise.octaves, base.mapParams.noise.octaves);
    EXPECT_EQ(s.mapParams.noise.tileable, base.mapParams.noise.tileable);
    EXPECT_EQ(s.mapParams.size, base.mapParams.size);
    EXPECT_FLOAT_EQ(s.params[shading::Param::Shininess], 90.0f);
    EXPECT_FLOAT_EQ(s.params[shading::Param::SpecularStrength], base.params[shading::Param::SpecularStrength]);
}

TEST(Tune, SvgHasOnePanelPerParameterAndTheTargetBand) {
    tune::SweepResult r;
    r.views = 2;
    r.size = 320;
    for (const char* k : {"frequency", "shininess"}) {
        const tune::TuneParam* p = &tune::findTuneParam(k);
        r.params.push_back(p);
        r.baseValues.push_back(p->min);
        for (double t : {p->min, p->max}) {
            tune::SweepPoint pt;
            pt.param = p;
            pt.value = t;
            pt.isBase = t == p->min;
            tune::FrameHighlights h;
            h.values.fill(t);
            pt.views = {h, h};
            pt.summary = tune::summarise(pt.views);
            r.points.push_back(pt);
        }
    }
    tune::HighlightSummary target = r.points[0].summary;
    const std::string svg = tune::sweepSvg(r, HighlightStat::Count, &target);
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_NE(svg.find("</svg>"), std::string::npos);
    auto countOf = [&](const std::string& what) {
        std::size_t n = 0;
        for (std::size_t p = svg.find(what); p != std::string::npos; p = svg.find(what, p + 1)) ++n;
        return n;
    };
    EXPECT_EQ(countOf("<polyline"), 2u);         // one median line per panel
    EXPECT_EQ(countOf("stroke-dasharray"), 2u);  // the scene's value in each
    EXPECT_EQ(countOf("fill=\"#2a2\""), 2u);     // the target band in each
    EXPECT_NE(svg.find("reflectance_map.frequency"), std::string::npos);
    const std::string tsv = tune::sweepTsv(r);
    EXPECT_EQ(std::count(tsv.begin(), tsv.end(), '\n'), 5);  // header + 4 points
    const nlohmann::json j = nlohmann::json::parse(tune::sweepJson(r, &target));
    EXPECT_EQ(j["params"].size(), 2u);
    EXPECT_EQ(j["params"][0]["points"][1]["views"].size(), 2u);
}

// A small scene that renders quickly on llvmpipe: the phantom with a small
// map, and a strong specular so every view has highlights to measure.
scene::Scene smallScene() {
    scene::Scene s = scene::defaultScene();
    s.mapParams.size = 256;
    s.params.set(shading::Param::SpecularStrength, 2.5f);
    s.params.set(shading::Param::Shininess, 40.0f);  // the start of the recovery below
    return s;
}

TEST(Tune, FitRecoversAShininessFromItsHighlights) {
    const scene::Scene s = smallScene();
    tune::ProbeOptions po;
    po.views = 6;
    po.size = 320;
    const tune::TuneParam& shin = tune::findTuneParam("shininess");
    // The target: the same views at a known shininess, 2.5x the scene's 40.
    constexpr double kTrue = 100;
    tune::HighlightSummary target;
    {
        tune::HighlightProbe probe(s, po);
        target = tune::summarise(probe.measure({{&shin, kTrue}}));
    }
    ASSERT_GT(target[HighlightStat::Count].median, 0) << "no highlights at the target setting: nothing to fit";
    tune::TuneFitOptions o;
    o.params = {"material.shininess"};
    o.probe = po;
    o.maxEvaluations = 24;
    int calls = 0, last = 0;
    o.progress = [&](int done, int total, double) {
        EXPECT_GT(done, last);  // one call per new render of the views
        EXPECT_EQ(total, 24);
        last = done;
        ++calls;
    };
    const tune::TuneFitResult r = tune::fitToTarget(s, target, o);
    ASSERT_EQ(r.best.size(), 1u);
    EXPECT_DOUBLE_EQ(r.start[0].second, 40.0);
    EXPECT_LT(r.after.total, 0.5 * r.before.total);
    // Within 25 % of the true value: the statistics count pixels, so nearby
    // shininess values give the same frames (measured: 97.4, distance 1.62 -> 0.05). Six views: with
    // four, the veiling glare's small shifts were enough to move the noisy optimum to 207.
    EXPECT_NEAR(std::log(r.best[0].second / kTrue), 0.0, std::log(1.25))
        << "fitted " << r.best[0].second << ", true " << kTrue << ", distance " << r.after.total;
    EXPECT_LE(r.evaluations, 24);
    EXPECT_EQ(calls, r.evaluations);
    // Deterministic: the same search gives the same answer.
    o.progress = nullptr;
    const tune::TuneFitResult again = tune::fitToTarget(s, target, o);
    EXPECT_EQ(again.best[0].second, r.best[0].second);
    EXPECT_EQ(again.after.total, r.after.total);
}

TEST(Tune, SweepMeasuresEachValueAndSharesTheScenesOwn) {
    tune::SweepOptions o;
    o.params = {"specular_strength"};
    o.steps = 3;
    o.probe.views = 2;
    const tune::SweepResult r = tune::sweep(smallScene(), o);
    // 0.1, 0.548, 2.5 (the scene's), 3.
    ASSERT_EQ(r.points.size(), 4u);
    EXPECT_TRUE(r.points[2].isBase);
    EXPECT_FLOAT_EQ(static_cast<float>(r.points[2].value), 2.5f);
    // More specular, more highlight: k_s scales the lobe, so the highlight
    // area can only grow with it (the same views, the same lobe shapes).
    for (std::size_t i = 1; i < r.points.size(); ++i)
        EXPECT_GE(r.points[i].summary[HighlightStat::Fraction].median,
                  r.points[i - 1].summary[HighlightStat::Fraction].median);
    EXPECT_GT(r.points[3].summary[HighlightStat::Fraction].median, r.points[0].summary[HighlightStat::Fraction].median);
}

TEST(TuneCli, BadInputIsOneLine) {
    test::TempDir dir;
    auto oneError = [](const test::RunResult& r) {
        EXPECT_EQ(r.exitCode, 1) << r.err;
        EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    };
    test::RunResult r = test::runCli("tune fit --target '" + (dir / "missing.json").string() + "' -o '" +
                                     (dir / "p.json").string() + "'");
    oneError(r);
    EXPECT_NE(r.err.find("missing.json"), std::string::npos) << r.err;
    std::ofstream(dir / "bad.json") << "{\"frames\": [";
    r = test::runCli("tune fit --target '" + (dir / "bad.json").string() + "' -o '" + (dir / "p.json").string() + "'");
    oneError(r);
    EXPECT_NE(r.err.find("bad.json"), std::string::npos) << r.err;
    r = test::runCli("tune sweep --params shinyness -o '" + (dir / "out").string() + "'");
    oneError(r);
    EXPECT_NE(r.err.find("unknown parameter 'shinyness'"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "p.json"));
}

}  // namespace
