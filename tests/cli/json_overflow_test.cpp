// Numbers a double cannot hold (1e999) make nlohmann throw out_of_range, not
// parse_error: every JSON file the library reads turns that into one typed
// InputError naming the file, and the CLI into one `error:` line.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/fit/brdf.hpp>
#include <mucosa/fit/frames.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/render/scene.hpp>

#include "test_support.hpp"

namespace mucosa {
namespace {

void write(const std::filesystem::path& p, const std::string& text) {
    std::ofstream(p) << text;
}

TEST(JsonInput, OverflowingNumbersAreTypedErrorsNamingTheFile) {
    test::TempDir dir;
    const std::string huge = "1e999";
    struct Case {
        const char* name;
        std::string text;
        std::function<void(const std::filesystem::path&)> read;
    };
    const Case cases[] = {
        {"scene.json", R"({"mesh": "tube", "width": )" + huge + "}",
         [](const std::filesystem::path& p) { (void)render::loadScene(p); }},
        {"frames.json", R"({"units": "mm", "frames": [{"x": )" + huge + "}]}",
         [](const std::filesystem::path& p) { (void)fit::readFrames(p); }},
        {"brdf.json", R"({"c": [)" + huge + R"(, 0, 0, 0]})",
         [](const std::filesystem::path& p) { (void)fit::readBrdf(p); }},
        {"map.json", R"({"params": {"size": )" + huge + "}}",
         [](const std::filesystem::path& p) { (void)reflectance::readSidecar(p); }},
    };
    for (const Case& c : cases) {
        const auto path = dir / c.name;
        write(path, c.text);
        try {
            c.read(path);
            ADD_FAILURE() << c.name << " was accepted";
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), path.string()) << c.name;
            EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << c.name << ": " << e.what();
        } catch (const std::exception& e) {
            ADD_FAILURE() << c.name << ": untyped exception " << e.what();
        }
    }
}

TEST(JsonInput, CliPrintsOneErrorLineForAnOverflowingScene) {
    test::TempDir dir;
    write(dir / "scene.json", R"({"mesh": "tube", "width": 1e999})");
    const auto r = test::runCli("render '" + (dir / "scene.json").string() + "' -o '" + (dir / "f.png").string() + "'");
    EXPECT_NE(r.exitCode, 0);
    EXPECT_EQ(r.err.rfind("error: JSON in " + (dir / "scene.json").string() + ": ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "f.png"));
}

}  // namespace
}  // namespace mucosa
