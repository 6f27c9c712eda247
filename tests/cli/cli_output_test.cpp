// What the tool prints when things go right: help that does not repeat the
// parameter registry, counts in the right number, paths without doubled
// slashes, progress that only goes forward, and a log that survives a kill.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/mesh/io.hpp>
#include <mucosa/shading/params.hpp>

#include "cli_helpers.hpp"
#include "synthetic.hpp"
#include "test_support.hpp"

namespace mucosa::test {
namespace {

TEST(CliOutput, ParamsListsEveryModeAndEveryParameter) {
    const auto r = runCli("params");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const shading::ModeInfo& m : shading::modes()) {
        EXPECT_NE(r.out.find(std::string(m.name)), std::string::npos) << m.name;
        EXPECT_NE(r.out.find(std::string(m.description)), std::string::npos) << m.name;
    }
    EXPECT_NE(r.out.find(shading::registryHelp()), std::string::npos) << r.out;
    for (const shading::ParamInfo& p : shading::registry())
        EXPECT_NE(r.out.find(fmt::format("{}.{} (", p.group, p.name)), std::string::npos) << p.name;
}

TEST(CliOutput, SceneCommandsPointToParamsInsteadOfRepeatingTheRegistry) {
    const std::string firstParam =
        std::string(shading::registry()[0].group) + "." + std::string(shading::registry()[0].name);
    for (const char* command : {"render", "compare", "view", "phantom"}) {
        const auto r = runCli(std::string(command) + " --help");
        ASSERT_EQ(r.exitCode, 0) << command;
        EXPECT_EQ(r.out.find(firstParam + " ("), std::string::npos) << command << " still lists the registry";
        EXPECT_LT(lineCount(r.out), 40) << command << "\n" << r.out;
        if (std::string(command) != "phantom") {  // takes no shading parameters
            EXPECT_NE(r.out.find("mucosa params"), std::string::npos) << command;
        }
    }
    // The error for an unknown --set parameter points there too.
    expectOneErrorLine(runCli("render -o x.png --set material.shinyness=80"),
                       "unknown parameter 'material.shinyness' (did you mean 'material.shininess'? see mucosa params)");
}

TEST(CliOutput, CountsAreSingularForOne) {
    TempDir dir;
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "resolution": [32, 24]})";
    auto r = runCli("render tube.json -o f.png --frames 2", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("wrote 2 frames of f_0000.png .. f_0001.png"), std::string::npos) << r.out;
    std::filesystem::remove(dir / "f_0001.png");
    r = runCli("render tube.json -o f.png --frames 2", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("wrote 1 frame of f_0000.png .. f_0001.png"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("kept 1 existing"), std::string::npos) << r.out;

    // A study plan for one observer, from one image per category.
    nlohmann::json images = nlohmann::json::array();
    for (int c = 1; c <= 5; ++c) {
        const std::string name = fmt::format("c{}.png", c);
        std::ofstream(dir / name) << "not really a png";
        images.push_back({{"id", name}, {"file", name}, {"category", c}, {"patient", 1}, {"pose", c}});
    }
    std::ofstream(dir / "images.json") << nlohmann::json{{"images", images}}.dump();
    r = runCli("study plan --manifest images.json -o plan.json --observers 1 --twoafc 1 --series 1", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("1 observer slot, 5 images"), std::string::npos) << r.out;
}

// The numbers in "[fit NN%]" progress lines, in order.
std::vector<int> fitPercents(const std::string& err) {
    std::vector<int> p;
    const std::regex line(R"(\[fit +([0-9]+)%\])");
    for (auto it = std::sregex_iterator(err.begin(), err.end(), line); it != std::sregex_iterator(); ++it)
        p.push_back(std::stoi((*it)[1]));
    return p;
}

TEST(CliOutput, FitProgressOnlyGoesForwardAndItsPathsHaveNoDoubledSlash) {
    TempDir dir;
    const mesh::Mesh tube = makeTube(9, 80, 64, 64);
    mesh::save(tube, dir / "tube.ply");
    SyntheticOptions so;
    so.frames = 12;  // more frames than stages: the back-projection alone once reached 90 %
    so.size = 96;
    renderSynthetic(tube, Truth{}, so, dir.path());
    const auto r = runCli("fit --mesh tube.ply --frames frames.json -o out/ --texture-size 64 --holdout 2", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::vector<int> p = fitPercents(r.err);
    ASSERT_GE(p.size(), 16u) << r.err;  // reading, 12 frames, solve, texture, 2 held out, writing, done
    for (std::size_t i = 1; i < p.size(); ++i) EXPECT_LT(p[i - 1], p[i]) << "line " << i << ":\n" << r.err;
    EXPECT_EQ(p.front(), 0);
    EXPECT_EQ(p.back(), 100);
    // 100 % comes after the outputs are written, not before.
    EXPECT_LT(r.err.find("writing"), r.err.find("[fit 100%]")) << r.err;
    EXPECT_NE(r.out.find("wrote out/{brdf.json, texture.png, coverage.png, report.html}"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("//"), std::string::npos) << r.out;
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / "brdf.json"));
}

}  // namespace
}  // namespace mucosa::test
