// The camera's response in frames and camera files (tone curve, vignetting),
// and the synthetic patient `mucosa demo` and bench_patient run the patient
// pipeline on: its path, its video, what it writes.
#include <algorithm>
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/fit/fit.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/register/patient.hpp>
#include <mucosa/register/register.hpp>
#include <mucosa/shading/reference.hpp>

#include "test_support.hpp"

using namespace mucosa;

namespace {

void writeText(const std::filesystem::path& p, const std::string& text) {
    std::ofstream(p) << text;
}

const char* kFrame =
    R"("frames": [{"image": "f.png", "intrinsics": {"width": 33, "height": 33, "fx": 20, "fy": 20, "cx": 16, "cy": 16},
                   "camera_to_world": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}])";

// The synthetic patient of the tests: short, small, quick.
registration::PatientOptions smallPatient() {
    registration::PatientOptions o;
    o.frames = 160;
    o.size = 96;
    o.startMm = 70;
    return o;
}

}  // namespace

TEST(Response, ToneCurvesAreInvertedExactlyAndAPowerLawIsAPowerLaw) {
    for (int curve = 0; curve < 3; ++curve) {
        frames::Response r;
        r.toneCurve = curve;
        for (double s : {0.0, 0.001, 0.01, 0.018, 0.05, 0.2, 0.5, 0.9, 1.0})
            EXPECT_NEAR(r.linear(shading::toneCurve(static_cast<float>(s), curve)), s, 2e-5) << curve << " " << s;
    }
    // BT.709 at its published points: 0.018 -> 0.081, 1 -> 1, 0.5 -> 0.7055.
    EXPECT_NEAR(shading::toneCurve(0.5f, 1), 1.099 * std::pow(0.5, 0.45) - 0.099, 1e-5);
    const frames::Response power(2.2);
    EXPECT_NEAR(power.linear(0.5), std::pow(0.5, 2.2), 1e-12);
}

TEST(Response, FramesAndCameraFilesReadAndWriteToneCurveAndVignetting) {
    test::TempDir dir;
    writeText(dir / "frames.json",
              std::string(R"({"tone_curve": "bt709", "vignetting": 1.5, "flare": 0.03, )") + kFrame + "}");
    const frames::FrameSet set = frames::readFrames(dir / "frames.json");
    EXPECT_EQ(set.response.toneCurve, 1);
    EXPECT_DOUBLE_EQ(set.response.vignetting, 1.5);
    EXPECT_DOUBLE_EQ(set.response.flare, 0.03);
    // Written back: the same keys (and the image relative to the file).
    frames::writeFrames(dir / "again.json", set);
    const auto j = nlohmann::json::parse(std::ifstream(dir / "again.json"));
    EXPECT_EQ(j["tone_curve"], "bt709");
    EXPECT_EQ(j["vignetting"], 1.5);
    EXPECT_EQ(j["flare"], 0.03);
    EXPECT_FALSE(j.contains("gamma"));
    EXPECT_EQ(j["frames"][0]["image"], "f.png");
    const frames::FrameSet back = frames::readFrames(dir / "again.json");
    EXPECT_EQ(back.response.toneCurve, 1);
    EXPECT_DOUBLE_EQ(back.response.vignetting, 1.5);

    writeText(dir / "camera.json",
              R"({"intrinsics": {"width": 33, "height": 33, "fx": 20, "fy": 20, "cx": 16, "cy": 16},
                  "tone_curve": "srgb"})");
    EXPECT_EQ(frames::readCamera(dir / "camera.json").response.toneCurve, 2);
    EXPECT_EQ(frames::readCamera(dir / "camera.json").response.vignetting, 0.0);

    // Errors name the field.
    auto refused = [&](const std::string& keys, const std::string& field) {
        writeText(dir / "bad.json", "{" + keys + ", " + kFrame + "}");
        try {
            frames::readFrames(dir / "bad.json");
            ADD_FAILURE() << keys;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
        }
    };
    refused(R"("tone_curve": "log")", "'tone_curve'");
    refused(R"("tone_curve": 1)", "'tone_curve'");
    refused(R"("tone_curve": "bt709", "gamma": 2.2)", "'gamma'");
    refused(R"("vignetting": -1)", "'vignetting'");
    refused(R"("vignetting": 1e999)", "out of range");
    refused(R"("flare": -0.1)", "'flare'");
}

TEST(Response, LoadFrameImageDividesTheVignettingOut) {
    // A frame that is the vignetting cos^2 of the field angle itself (sRGB
    // encoded, 16 bits) decodes to a flat field.
    test::TempDir dir;
    frames::Frame f;
    f.image = dir / "f.png";
    f.K = {33, 33, 20, 20, 16, 16};
    image::Image16 img(33, 33, 3);
    for (int y = 0; y < 33; ++y)
        for (int x = 0; x < 33; ++x) {
            const double tx = (x - 16) / 20.0, ty = (y - 16) / 20.0;
            const double s = 0.5 / (1 + tx * tx + ty * ty);
            for (int c = 0; c < 3; ++c)
                img.at(x, y, c) = static_cast<std::uint16_t>(std::lround(65535 * shading::toneCurve(float(s), 2)));
        }
    image::writePng(f.image, img);
    frames::Response r;
    r.toneCurve = 2;
    r.vignetting = 2;
    const image::ImageF lin = fit::loadFrameImage(f, r);
    for (int y = 0; y < 33; y += 4)
        for (int x = 0; x < 33; x += 4) EXPECT_NEAR(lin.at(x, y, 1), 0.5, 2e-3) << x << " " << y;
    r.vignetting = 0;
    EXPECT_NEAR(fit::loadFrameImage(f, r).at(0, 0, 1), 0.5 / (1 + 2 * 0.8 * 0.8), 2e-3);
}

TEST(FieldOfView, BlackConnectedToTheBorderIsOutsideADarkLumenInsideIsNot) {
    // A 41 x 41 frame: a lit disc of radius 15 around a black lumen of radius
    // 3, black outside the disc (the scope's mask).
    image::ImageF img(41, 41, 3);
    auto r2 = [](int x, int y) { return (x - 20) * (x - 20) + (y - 20) * (y - 20); };
    for (int y = 0; y < 41; ++y)
        for (int x = 0; x < 41; ++x)
            for (int c = 0; c < 3; ++c) img.at(x, y, c) = r2(x, y) <= 15 * 15 && r2(x, y) > 3 * 3 ? 0.3f : 0.0f;
    for (int c = 0; c < 3; ++c) img.at(20, 8, c) = 0.0f;  // a black pixel in the tissue, enclosed by it
    img.at(20, 34, 1) = img.at(20, 34, 2) = 0.0f;         // black in two channels only: not black
    img.at(20, 35, 1) = img.at(20, 35, 2) = 0.0f;         // the same, on the disc's edge
    const std::vector<std::uint8_t> out = fit::outsideFieldOfView(img);
    for (int y = 0; y < 41; ++y)
        for (int x = 0; x < 41; ++x)
            EXPECT_EQ(out[static_cast<std::size_t>(y) * 41 + x], r2(x, y) > 15 * 15 ? 1 : 0) << x << " " << y;
    // Widened by 2 pixels: everything within 2 (Chebyshev) of an outside pixel.
    const std::vector<std::uint8_t> wide = fit::outsideFieldOfView(img, 2);
    for (int y = 0; y < 41; ++y)
        for (int x = 0; x < 41; ++x) {
            bool near = false;
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx) {
                    const int u = x + dx, v = y + dy;
                    near = near || (u >= 0 && v >= 0 && u < 41 && v < 41 && out[static_cast<std::size_t>(v) * 41 + u]);
                }
            EXPECT_EQ(wide[static_cast<std::size_t>(y) * 41 + x], near ? 1 : 0) << x << " " << y;
        }
}

TEST(FieldOfView, LoadFrameImageMasksItAndSaturation) {
    test::TempDir dir;
    frames::Frame f;
    f.image = dir / "f.png";
    f.K = {21, 21, 60, 60, 10, 10};
    image::Image8 img(21, 21, 3);
    for (int y = 0; y < 21; ++y)
        for (int x = 0; x < 21; ++x)
            for (int c = 0; c < 3; ++c)
                img.at(x, y, c) =
                    (x - 10) * (x - 10) + (y - 10) * (y - 10) <= 64 ? (x == 10 && y == 10 ? 255 : 100) : 0;
    image::writePng(f.image, img);
    image::Image8 mask;
    fit::loadFrameImage(f, frames::Response{}, &mask);
    EXPECT_EQ(mask.at(10, 10), fit::kMaskSaturated);
    EXPECT_EQ(mask.at(0, 0), fit::kMaskOutsideView);
    EXPECT_EQ(mask.at(10, 2), fit::kMaskOutsideView);  // on the disc, within the margin of its edge
    EXPECT_EQ(mask.at(10, 5), 0);                      // 3 pixels in, and no outside pixel within 2 of it
    EXPECT_EQ(mask.at(12, 10), 0);
}

TEST(SyntheticPatient, PathGoesForwardPausesPullsBackAndRollsInsideTheAirway) {
    const registration::PatientOptions o = smallPatient();
    const registration::SyntheticPatient p = registration::makeSyntheticPatient(o);
    ASSERT_EQ(p.poses.size(), 160u);
    ASSERT_EQ(p.exposureFactors.size(), 160u);
    int still = 0, back = 0, forward = 0;
    double minRoll = 0, maxRoll = 0;
    const frames::Vec3d start = frames::cameraCentre(p.poses.front());
    double lastFromStart = 0;
    for (std::size_t i = 1; i < p.poses.size(); ++i) {
        const registration::PoseError step = registration::poseError(p.poses[i - 1], p.poses[i]);
        EXPECT_LE(step.position, o.speedMm * 1.2 + 0.05) << i;  // a scope, not a jump
        EXPECT_LE(step.degrees, 6.0) << i;
        const frames::Vec3d c = frames::cameraCentre(p.poses[i]);
        const double fromStart = std::hypot(c[0] - start[0], c[1] - start[1], c[2] - start[2]);
        still += step.position < 1e-6;
        back += fromStart < lastFromStart - 0.1;
        forward += fromStart > lastFromStart + 0.1;
        lastFromStart = fromStart;
    }
    EXPECT_GE(still, 20);  // two cycles of 8 + 7 still frames
    EXPECT_GE(back, 15);   // and two pull-backs of 10 frames
    EXPECT_GE(forward, 90);
    // Rolls: the camera's x axis turns about the view both ways.
    for (std::size_t i = 0; i < p.poses.size(); ++i) {
        const auto& m = p.poses[i];
        const double roll = std::atan2(m[1][0], m[0][0]) * 180 / M_PI;  // not a pure roll angle, but it swings
        minRoll = std::min(minRoll, roll - std::atan2(p.poses[0][1][0], p.poses[0][0][0]) * 180 / M_PI);
        maxRoll = std::max(maxRoll, roll - std::atan2(p.poses[0][1][0], p.poses[0][0][0]) * 180 / M_PI);
    }
    EXPECT_GT(maxRoll - minRoll, 20.0);
    for (double e : p.exposureFactors) {
        EXPECT_GE(e, 0.7);
        EXPECT_LE(e, 1.3);
    }
    // Every pose is one registration can start from: inside, facing the lumen.
    for (std::size_t i = 0; i < p.poses.size(); i += 20)
        EXPECT_NO_THROW(registration::checkInitialView(p.mesh, p.camera.K, p.poses[i], p.camera.lightOffset, "m", "p"))
            << i;
    // Deterministic.
    EXPECT_EQ(registration::makeSyntheticPatient(o).poses, p.poses);
    // Out of range: refused before any work.
    registration::PatientOptions bad = o;
    bad.exposureJitter = 1.5;
    EXPECT_THROW(registration::makeSyntheticPatient(bad), InputError);
    bad = o;
    bad.startMm = 1000;
    EXPECT_THROW(registration::makeSyntheticPatient(bad), InputError);
}

TEST(SyntheticPatient, WritesTheVideoCameraInitialPoseAndTheTruth) {
    registration::PatientOptions o = smallPatient();
    o.frames = 6;
    const registration::SyntheticPatient p = registration::makeSyntheticPatient(o);
    test::TempDir dir;
    int shown = 0;
    registration::PatientWriteOptions wo;
    wo.progress = [&](int done, int total) {
        EXPECT_EQ(total, 6);
        shown = done;
    };
    registration::writeSyntheticPatient(p, dir.path(), wo);
    EXPECT_EQ(shown, 6);
    const frames::CameraModel cam = frames::readCamera(dir / "camera.json");
    EXPECT_EQ(cam.K.width, 96);
    EXPECT_EQ(cam.response.toneCurve, 1);  // BT.709, the scope's video
    EXPECT_NEAR(cam.lightOffset[1], 1.2, 1e-12);
    // The initial pose is the truth moved by 1 mm and 2 degrees.
    const registration::PoseError e = registration::poseError(frames::readPose(dir / "init.json"), p.poses.front());
    EXPECT_NEAR(e.position, 1.0, 1e-6);
    EXPECT_NEAR(e.degrees, 2.0, 0.01);
    const frames::FrameSet truth = frames::readFrames(dir / "truth" / "frames.json");
    ASSERT_EQ(truth.frames.size(), 6u);
    EXPECT_EQ(truth.frames[3].cameraToWorld, p.poses[3]);
    EXPECT_TRUE(std::filesystem::exists(dir / "truth" / "brdf.json"));
    EXPECT_TRUE(std::filesystem::exists(dir / "airway.glb"));
    // The frames: the scope's round field of view (black corners), lit tissue
    // inside, a dark lumen ahead, and the exposure differs frame to frame.
    double previousMean = -1;
    int differ = 0;
    for (const frames::Frame& f : truth.frames) {
        const image::PngImage png = image::readPng(f.image);
        ASSERT_EQ(png.pixels.width(), 96);
        EXPECT_EQ(png.pixels.at(0, 0, 0), 0);
        EXPECT_EQ(png.pixels.at(95, 95, 1), 0);
        double sum = 0;
        int n = 0, bright = 0, darkest = 255;
        for (int y = 20; y < 76; ++y)
            for (int x = 20; x < 76; ++x) {
                const int v = png.pixels.at(x, y, 1);
                sum += v, ++n;
                bright += v > 60;
                darkest = std::min(darkest, v);
            }
        EXPECT_GT(bright, n / 5) << f.image;
        EXPECT_LT(darkest, 40) << f.image;  // the lumen ahead
        const double mean = sum / n;
        differ += previousMean >= 0 && std::abs(mean - previousMean) > 1.0;
        previousMean = mean;
    }
    EXPECT_GE(differ, 2);
}

// A patient's CT airway instead of the phantom: centerline UVs computed on
// it, the path along its own centerline's longest branch, cut where it
// leaves the lumen, every pose inside facing along it, and the video
// renders the tissue there.
TEST(SyntheticPatient, FliesAlongACtAirwaysOwnCenterline) {
    registration::PatientOptions o;
    o.meshFile = test::testdata("airway/vh_m_airway_lumen.obj");
    o.frames = 300;  // long enough to reach where its centerline leaves the lumen
    o.size = 96;
    o.startMm = 30;
    const registration::SyntheticPatient p = registration::makeSyntheticPatient(o);
    ASSERT_EQ(p.poses.size(), 300u);
    // The VH airway's longest computed path crosses a gap between its pieces
    // about 130 mm from the start: the scope stops before it.
    EXPECT_GT(p.pathStopMm, 100.0);
    EXPECT_TRUE(p.mesh.hasUvs());
    EXPECT_TRUE(p.mesh.hasTangents());
    EXPECT_FALSE(p.branch.empty());
    for (std::size_t i = 1; i < p.poses.size(); ++i) {
        const registration::PoseError step = registration::poseError(p.poses[i - 1], p.poses[i]);
        EXPECT_LE(step.position, o.speedMm * 1.2 + 0.05) << i;
        EXPECT_LE(step.degrees, 6.0) << i;
    }
    // The path ends before the schedule does, and the scope turns back
    // there: no stretch of still frames is longer than the schedule's
    // pauses (8), where it once stood 65 frames facing the wall.
    int still = 0, longest = 0;
    for (std::size_t i = 1; i < p.poses.size(); ++i) {
        still = registration::poseError(p.poses[i - 1], p.poses[i]).position < 1e-9 ? still + 1 : 0;
        longest = std::max(longest, still);
    }
    EXPECT_LE(longest, 8);
    for (std::size_t i = 0; i < p.poses.size(); i += 15)
        EXPECT_NO_THROW(registration::checkInitialView(p.mesh, p.camera.K, p.poses[i], p.camera.lightOffset, "ct", "p"))
            << i;
    EXPECT_NO_THROW(
        registration::checkInitialView(p.mesh, p.camera.K, p.poses.back(), p.camera.lightOffset, "ct", "p"));
    // The trachea runs along +y (504..660 mm), the scope goes down it.
    EXPECT_LT(frames::cameraCentre(p.poses.back())[1], frames::cameraCentre(p.poses.front())[1] - 20);
    registration::PatientVideo video(p);
    const image::Image8 f = video.frame(10);
    int lit = 0;
    for (int y = 20; y < 76; ++y)
        for (int x = 20; x < 76; ++x) lit += f.at(x, y, 0) > 60;
    EXPECT_GT(lit, 56 * 56 / 4);
    // A file that is not there: one InputError/IoError, nothing built.
    o.meshFile = "/nonexistent/airway.obj";
    EXPECT_THROW(registration::makeSyntheticPatient(o), Error);
}

// The first frame of the synthetic patient as `mucosa register` takes it,
// from the initial pose (1 mm, 2 degrees off), at bench_patient's size.
namespace {

struct FirstFrame {
    registration::SyntheticPatient patient;
    registration::VideoFrame frame;
    frames::Mat4 init{}, truth{};
    registration::RegisterOptions options;
};

FirstFrame firstFrame(registration::PatientLook look) {
    registration::PatientOptions o;
    o.look = look;
    o.frames = 2;
    o.size = 320;
    o.startMm = 60;
    FirstFrame f{registration::makeSyntheticPatient(o), {}, {}, {}, {}};
    test::TempDir dir;
    registration::writeSyntheticPatient(f.patient, dir.path());
    const frames::FrameSet truth = frames::readFrames(dir / "truth" / "frames.json");
    f.init = frames::readPose(dir / "init.json");
    f.truth = truth.frames[0].cameraToWorld;
    image::Image8 sat;
    const image::ImageF linear = fit::loadFrameImage(truth.frames[0], truth.response, &sat, 0.97);
    f.options.lightOffset = truth.lightOffset;
    f.options.lamp = f.patient.camera.lamp;
    if (look == registration::PatientLook::Category4) f.options.brdf = f.patient.brdf;
    f.frame = registration::prepareFrame(linear, &sat, f.patient.camera.K, f.options);
    return f;
}

}  // namespace

// Category 4: a coarse level (40 px) can prefer a roll far off, which the
// finest level, started there, keeps; the finest level run from the start
// too (recheck, what registerInitial's refinement does) finds the better
// pose. With normals compared (not gradients) the coarse level does not jump
// on this frame: registered from the initial pose it lands within 1 mm and
// 2.5 degrees (measured 2.1 degrees on the phantom's irregular rings). The
// recheck is then forced (thresholds 0): both runs are counted, and the
// better of the two kept.
TEST(SyntheticPatient, AFirstFramesCoarseJumpIsRecheckedAtTheFinestLevel) {
    const FirstFrame f = firstFrame(registration::PatientLook::Category4);
    const registration::FrameRegistration plain =
        registration::registerFrame(f.patient.mesh, f.frame, f.init, f.options);
    registration::RegisterOptions re = f.options;
    re.recheck = true;
    re.recheckMm = re.recheckDeg = 0;
    const registration::FrameRegistration rechecked = registration::registerFrame(f.patient.mesh, f.frame, f.init, re);
    const registration::PoseError ep = registration::poseError(plain.cameraToWorld, f.truth);
    const registration::PoseError er = registration::poseError(rechecked.cameraToWorld, f.truth);
    std::printf(
        "from the initial pose: %.2f mm %.2f deg (S %.4f, %d evaluations); rechecked %.2f mm %.2f deg "
        "(S %.4f, %d evaluations)\n",
        ep.position, ep.degrees, plain.similarity, plain.evaluations, er.position, er.degrees, rechecked.similarity,
        rechecked.evaluations);
    EXPECT_LT(ep.position, 1.0);
    EXPECT_LT(ep.degrees, 2.5);
    EXPECT_LT(er.position, 1.0);
    EXPECT_LT(er.degrees, 2.5);
    EXPECT_GE(rechecked.similarity, plain.similarity);
    EXPECT_GT(rechecked.evaluations, plain.evaluations);  // the finest level ran again from the start
}

// Lamp: the search settled one tracheal ring (5 mm) along, scoring 0.006
// above the truth's pose (0.9399 against 0.9393 for the pose near the
// initial one); among results within InitialSearch::tie of the best, the one
// nearest the initial pose is kept: within 1 mm (not a ring along) and 6
// degrees (measured 5.1 on the phantom's irregular rings).
TEST(SyntheticPatient, TheFirstFramesSearchKeepsTheRingNearestTheInitialPose) {
    const FirstFrame f = firstFrame(registration::PatientLook::Lamp);
    const registration::FrameRegistration r = registration::registerInitial(f.patient.mesh, f.frame, f.init, f.options);
    const registration::PoseError e = registration::poseError(r.cameraToWorld, f.truth);
    std::printf("searched: %.2f mm %.2f deg (S %.4f)\n", e.position, e.degrees, r.similarity);
    EXPECT_TRUE(r.converged);
    EXPECT_LT(e.position, 1.0);
    EXPECT_LT(e.degrees, 6.0);
}
