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

// stdout is line-buffered even into a file: a run killed half way keeps the
// lines it printed (block buffering would keep them in memory until exit).
TEST(CliOutput, AKilledRunKeepsItsLog) {
    TempDir dir;
    std::ofstream(dir / "tube.json") << R"({"mesh": "tube", "resolution": [16, 16]})";
    const std::filesystem::path log = dir / "log.txt";
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int null = ::open("/dev/null", O_WRONLY);
        ::dup2(fd, 1);
        ::dup2(null, 2);
        ::chdir(dir.path().c_str());
        // Long enough never to finish before it is killed.
        ::execl(MUCOSA_CLI, MUCOSA_CLI, "render", "tube.json", "-o", "f.png", "--frames", "100000", nullptr);
        ::_exit(127);
    }
    bool logged = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (!logged && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        logged = readBytes(log).find("GL_RENDERER") != std::string::npos;
        int status = 0;
        if (::waitpid(pid, &status, WNOHANG) == pid) {
            ADD_FAILURE() << "mucosa render ended on its own:\n" << readBytes(log);
            return;
        }
    }
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
    EXPECT_TRUE(logged) << "nothing in the log of a running render after 120 s:\n" << readBytes(log);
    EXPECT_NE(readBytes(log).find("tube: radius"), std::string::npos) << readBytes(log);
}

}  // namespace
}  // namespace mucosa::test
