// mucosa demo's patient pipeline, end to end (register -> fit -> categories
// -> study plan on a synthetic patient). Its own binary: under the
// sanitizers it takes several minutes, beyond the other tests' timeout.
#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>

#include "test_support.hpp"

using mucosa::test::runCli;
using mucosa::test::TempDir;

TEST(DemoCli, RunsThePatientPipelineOnASyntheticPatientAndScoresIt) {
    TempDir dir;
    const auto r = runCli("demo --patient-frames 4", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::filesystem::path p = dir / "out" / "patient";
    // What a clinical user brings, and what each step wrote.
    for (const char* f : {"input/airway.glb", "input/camera.json", "input/init.json", "input/video/frame_0003.png",
                          "frames.json", "register_report/index.html", "fit/brdf.json", "fit/texture.png",
                          "stimuli/images.json", "stimuli/pose000_cat4.png", "study.json"})
        EXPECT_TRUE(std::filesystem::exists(p / f)) << f;
    // Scored against the truth it never read: most frames register near it.
    int converged = 0, frames = 0;
    double medianMm = 0;
    const auto line = r.out.find(" frames converged; pose error median ");
    ASSERT_NE(line, std::string::npos) << r.out;
    const auto start = r.out.rfind("patient: ", line);
    ASSERT_EQ(std::sscanf(r.out.c_str() + start, "patient: %d of %d frames converged; pose error median %lf",
                          &converged, &frames, &medianMm),
              3)
        << r.out;
    EXPECT_EQ(frames, 4);
    EXPECT_GE(converged, 3) << r.out;
    EXPECT_LT(medianMm, 2.0) << r.out;
    EXPECT_NE(r.out.find("recovered texture PSNR"), std::string::npos) << r.out;
}
