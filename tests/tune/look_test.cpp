// The look fit (tune/look.hpp): a look is recovered from frames rendered
// with it, the fitted look is a file --look reads back to the same values,
// and the command refuses bad input in one line.
#include <mucosa/tune/look.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/scene/scene.hpp>
#include <mucosa/shading/params.hpp>

#include "test_support.hpp"

namespace {

using namespace mucosa;
namespace fs = std::filesystem;

scene::Scene smallScene() {
    scene::Scene s = scene::defaultScene();
    s.mapParams.size = 256;
    return s;
}

TEST(Look, FitRecoversATissueHueAndTheCamerasSaturationFromFrames) {
    // The target: six views of the phantom with a redder mucosa (hue 30 deg,
    // the default 41) through a processor with less colour gain (1.1, the
    // default 1.5).
    const scene::Scene s = smallScene();
    const tune::TuneParam& hue = tune::findTuneParam("tissue.hue");
    const tune::TuneParam& sat = tune::findTuneParam("camera.saturation");
    tune::ProbeOptions po;
    po.views = 6;
    po.size = 160;
    std::vector<tune::FrameStats> target;
    {
        tune::HighlightProbe probe(s, po);
        for (const image::Image8& f : probe.renderViews({{&hue, 30.0}, {&sat, 1.1}}))
            target.push_back(tune::measureFrame(f));
    }
    tune::LookFitOptions o;
    o.params = {"tissue.hue", "camera.saturation"};
    o.probe = po;
    o.maxEvaluations = 30;
    o.tolerance = 1.0 / 64;
    const tune::LookFitResult r = tune::fitLook(s, target, o);
    ASSERT_EQ(r.best.size(), 2u);
    EXPECT_EQ(r.start[0].second, 41.0);
    // The search's grid about the start (steps of 1/4 .. 1/64 of 15..70 deg
    // and of log(0.7..3)) holds points within 0.45 deg and 1.2 % of the truth.
    EXPECT_NEAR(r.best[0].second, 30.0, 1.5) << "hue";
    EXPECT_NEAR(std::log(r.best[1].second / 1.1), 0.0, 0.05) << "saturation " << r.best[1].second;
    EXPECT_LT(r.after.realism.overall, 0.3 * r.before.realism.overall);
    EXPECT_LT(r.after.objective, r.before.objective);
    EXPECT_LE(r.evaluations, 30);
    EXPECT_EQ(r.frames.size(), 6u);
}

TEST(Look, AProbeWithPatientsRendersEachAboutTheLook) {
    tune::ProbeOptions po;
    po.views = 2;
    po.size = 64;
    po.patients = 2;
    po.asLook = true;
    tune::HighlightProbe probe(smallScene(), po);
    const tune::TuneParam& chroma = tune::findTuneParam("tissue.chroma");
    const std::vector<image::Image8> plain = probe.renderViews({});
    ASSERT_EQ(plain.size(), 6u);  // the scene's two views, then each patient's
    EXPECT_NE(plain[0], plain[2]);
    EXPECT_NE(plain[2], plain[4]);
    // A greyer look: every view, the scene's and the patients', less saturated.
    const std::vector<image::Image8> grey = probe.renderViews({{&chroma, 12.0}});
    ASSERT_EQ(grey.size(), 6u);
    auto chromaOf = [](const image::Image8& f) { return tune::measureFrame(f)[tune::FrameStat::ChromaMean]; };
    for (std::size_t i = 0; i < 6; ++i) EXPECT_LT(chromaOf(grey[i]), chromaOf(plain[i]) - 3) << i;
    // The same values give the same frames (the texture made once per setting).
    EXPECT_EQ(probe.renderViews({}), plain);
}

TEST(Look, AFitOfAPatientStartsFromTheCentreItVariesAbout) {
    // Patient 3's hue is drawn about the look; the fit's start is the centre
    // (the default look's 41 deg), not the patient's own hue.
    scene::Scene s = smallScene();
    scene::applyVariation(s, 3);
    ASSERT_NE(scene::tissueParams(s).hue, 41.0);
    tune::LookFitOptions o;
    o.params = {"tissue.hue"};
    o.probe.views = 2;
    o.probe.size = 64;
    o.maxEvaluations = 1;
    std::vector<tune::FrameStats> target;
    {
        tune::HighlightProbe probe(smallScene(), o.probe);
        for (const image::Image8& f : probe.renderViews({})) target.push_back(tune::measureFrame(f));
    }
    const tune::LookFitResult r = tune::fitLook(s, target, o);
    EXPECT_EQ(r.start[0].second, 41.0);
    EXPECT_EQ(r.evaluations, 1);
}

TEST(Look, TheFittedLookIsAFileThatLookReadsBack) {
    const scene::Scene s = smallScene();
    tune::TuneValues values;
    for (const auto& [key, v] :
         {std::pair{"tissue.chroma", 25.0}, std::pair{"camera.saturation", 1.25}, std::pair{"material.sheen", 0.4},
          std::pair{"light.spread", 1.0}, std::pair{"camera.full_well", 9000.0}})
        values.push_back({&tune::findTuneParam(key), v});
    test::TempDir dir;
    const fs::path look = dir / "look.json";
    std::ofstream(look) << tune::presetJson(s, values, false);
    scene::Scene back = scene::defaultScene();
    scene::applyLook(back, look);
    for (const auto& [p, v] : values) EXPECT_NEAR(tune::tuneValue(back, *p), v, 1e-5 * v) << p->key;
    // Only what was fitted: the map keeps the scene's parameters.
    EXPECT_EQ(back.mapParams.noise.frequency, scene::defaultScene().mapParams.noise.frequency);
    EXPECT_EQ(tune::lookGroup(tune::findTuneParam("camera.read_noise")), tune::LookGroup::Camera);
}

TEST(LookCli, BadInputIsOneLineAndNothingIsWritten) {
    test::TempDir dir;
    auto r = test::runCli("look fit " + (dir / "nowhere").string() + " -o " + (dir / "l.json").string());
    EXPECT_NE(r.exitCode, 0);
    EXPECT_EQ(r.err, "error: frames in " + (dir / "nowhere").string() + ": no such file or folder\n");
    std::ofstream(dir / "one.json") << R"({"frames": [{"name": "a", "stats": {"L_mean": 50}}]})";
    r = test::runCli("look fit " + (dir / "one.json").string() + " -o " + (dir / "l.json").string());
    EXPECT_NE(r.exitCode, 0);
    EXPECT_NE(r.err.find("a fit needs at least 2"), std::string::npos) << r.err;
    r = test::runCli("look fit " + (dir / "one.json").string() + " -o " + (dir / "l.png").string());
    EXPECT_NE(r.exitCode, 0);
    EXPECT_NE(r.err.find("must end in .json"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "l.json"));
    r = test::runCli("render -o " + (dir / "f.png").string() + " --size 32x32 --look " +
                     (dir / "missing.json").string());
    EXPECT_NE(r.exitCode, 0);
    EXPECT_FALSE(fs::exists(dir / "f.png"));
}

TEST(LookCli, StatsAndCompareMeasureFoldersOfFrames) {
    // Two folders of three frames: salmon and grey with a little texture.
    test::TempDir dir;
    fs::create_directories(dir / "real");
    fs::create_directories(dir / "ours");
    for (int i = 0; i < 3; ++i) {
        image::Image8 a(64, 64, 3), b(64, 64, 3);
        for (int y = 0; y < 64; ++y)
            for (int x = 0; x < 64; ++x) {
                const int t = (x * 7 + y * 3 + i * 11) % 9;
                a.at(x, y, 0) = static_cast<std::uint8_t>(200 + t);
                a.at(x, y, 1) = static_cast<std::uint8_t>(120 + t);
                a.at(x, y, 2) = static_cast<std::uint8_t>(100 + t);
                for (int c = 0; c < 3; ++c) b.at(x, y, c) = static_cast<std::uint8_t>(140 + t);
            }
        image::writePng(dir / "real" / fmt::format("r{}.png", i), a);
        image::writePng(dir / "ours" / fmt::format("o{}.png", i), b);
    }
    auto r = test::runCli("look stats " + (dir / "real").string());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.out.rfind("frame\tL_mean\tL_std\t", 0), 0u) << r.out;
    EXPECT_NE(r.out.find("\nr2.png\t"), std::string::npos);
    EXPECT_NE(r.out.find("\nmedian\t"), std::string::npos);
    r = test::runCli("look compare " + (dir / "real").string() + " " + (dir / "ours").string());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // Grey against salmon: a* far from the real median, told apart every time.
    EXPECT_NE(r.out.find("AUC 1.000"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("realism score"), std::string::npos);
    r = test::runCli("look compare " + (dir / "real").string() + " " + (dir / "none").string());
    EXPECT_NE(r.exitCode, 0);
    EXPECT_EQ(r.err, "error: frames in " + (dir / "none").string() + ": no such file or folder\n");
}

}  // namespace
