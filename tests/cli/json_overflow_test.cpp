// Numbers a double cannot hold (1e999) make nlohmann throw out_of_range, not
// parse_error: every JSON file the library reads turns that into one typed
// InputError naming the file, and the CLI into one `error:` line. Syntax
// errors (a trailing comma) are reported at their line and column.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/frames/frames.hpp>
#include <mucosa/mesh/centerline.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/scene/scene.hpp>
#include <mucosa/shading/brdf.hpp>
#include <mucosa/study/plan.hpp>

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
         [](const std::filesystem::path& p) { (void)scene::loadScene(p); }},
        {"frames.json", R"({"units": "mm", "frames": [{"x": )" + huge + "}]}",
         [](const std::filesystem::path& p) { (void)frames::readFrames(p); }},
        {"brdf.json", R"({"c": [)" + huge + R"(, 0, 0, 0]})",
         [](const std::filesystem::path& p) { (void)shading::readBrdf(p); }},
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

// A trailing comma on line 3 of every kind of JSON file the library reads:
// one InputError naming the file, at line 3, at the '}' that follows the comma
// (column 1 of line 4 would be wrong: the parser stops at the '}'), and the
// message reads "<file>:3:<column>: JSON: ...".
TEST(JsonInput, SyntaxErrorsNameTheFileLineAndColumn) {
    test::TempDir dir;
    struct Case {
        const char* name;
        std::string text;  // a trailing comma before the '}' on line 3
        int column;        // of that '}'
        std::function<void(const std::filesystem::path&)> read;
        const char* subject;
    };
    const Case cases[] = {
        {"scene.json", "{\n  \"mesh\": \"tube\",\n  \"frames\": 2,}\n", 15,
         [](const std::filesystem::path& p) { (void)scene::loadScene(p); }, "JSON"},
        {"frames.json", "{\n  \"units\": \"mm\",\n  \"frames\": [],}\n", 16,
         [](const std::filesystem::path& p) { (void)frames::readFrames(p); }, "JSON"},
        {"brdf.json", "{\n  \"c\": [0, 1, 0, 0],\n  \"d\": [0, 0, 0],}\n", 18,
         [](const std::filesystem::path& p) { (void)shading::readBrdf(p); }, "JSON"},
        {"map.json", "{\n  \"params\":\n  {\"size\": 64},}\n", 16,
         [](const std::filesystem::path& p) { (void)reflectance::readSidecar(p); }, "JSON"},
        {"c.centerline.json", "{\n  \"units\": \"mm\",\n  \"branches\": [],}\n", 18,
         [](const std::filesystem::path& p) { (void)mesh::readCenterlineJson(p); }, "JSON"},
        {"images.json", "{\n  \"images\":\n  [],}\n", 6,
         [](const std::filesystem::path& p) { (void)study::readManifest(p); }, "manifest"},
        {"study.json", "{\n  \"format\":\n  \"x\",}\n", 7,
         [](const std::filesystem::path& p) { (void)study::readPlan(p); }, "plan"},
    };
    for (const Case& c : cases) {
        const auto path = dir / c.name;
        write(path, c.text);
        try {
            c.read(path);
            ADD_FAILURE() << c.name << " was accepted";
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), path.string()) << c.name;
            EXPECT_EQ(e.subject(), c.subject) << c.name;
            EXPECT_EQ(e.line(), 3) << c.name << ": " << e.what();
            EXPECT_EQ(e.column(), c.column) << c.name << ": " << e.what();
            const std::string where = fmt::format("{}:3:{}: {}: ", path.string(), c.column, c.subject);
            EXPECT_EQ(std::string(e.what()).rfind(where, 0), 0u) << c.name << ": " << e.what();
            EXPECT_EQ(std::string(e.what()).find("[json.exception"), std::string::npos) << e.what();
        } catch (const std::exception& e) {
            ADD_FAILURE() << c.name << ": untyped exception " << e.what();
        }
    }
}

TEST(JsonInput, CliPrintsFileLineAndColumnForATrailingComma) {
    test::TempDir dir;
    write(dir / "scene.json", "{\n  \"mesh\": \"tube\",\n}\n");
    const auto r = test::runCli("render '" + (dir / "scene.json").string() + "' -o '" + (dir / "f.png").string() + "'");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(r.err.rfind("error: " + (dir / "scene.json").string() + ":3:1: JSON: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("unexpected '}'"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "f.png"));
}

// Whole numbers are taken whole or refused: never wrapped or truncated
// (4294967297 is not 1, -1 is not 18446744073709551615), and a float field
// holds a finite float.
TEST(JsonInput, IntegersOutOfRangeAreRefusedNotTruncated) {
    test::TempDir dir;
    struct Case {
        const char* name;
        std::string text;
        std::function<void(const std::filesystem::path&)> read;
        const char* field;
    };
    const auto scene = [](const std::filesystem::path& p) { (void)scene::loadScene(p); };
    const auto sidecar = [](const std::filesystem::path& p) { (void)reflectance::readSidecar(p); };
    const auto centerline = [](const std::filesystem::path& p) { (void)mesh::readCenterlineJson(p); };
    const std::string branch = R"("points": [[0, 0, 0]], "radii": [1])";
    const Case cases[] = {
        {"s1.json", R"({"mesh": "tube", "frames": 18446744073709551615})", scene, "frames"},
        {"s2.json", R"({"mesh": "tube", "frames": 4294967297})", scene, "frames"},
        {"m1.json", R"({"params": {"octaves": 4294967300}})", sidecar, "octaves"},
        {"m2.json", R"({"params": {"seed": -1}})", sidecar, "seed"},
        {"m3.json", R"({"params": {"size": 18446744073709551615}})", sidecar, "size"},
        {"c1.json", R"({"branches": [{"parent": 4294967295, )" + branch + "}]}", centerline, "branches[0].parent"},
        {"c2.json", R"({"branches": [{"parent": -1, )" + branch + R"(}, {"parent": 1, )" + branch + "}]}", centerline,
         "branches[1].parent"},
        {"c3.json", R"({"branches": [{"parent": -1, "points": [[0, 1e39, 0]], "radii": [1]}]})", centerline,
         "branches[0].points[0]"},
        {"c4.json", R"({"branches": [{"parent": "root", )" + branch + "}]}", centerline, "branches[0].parent"},
    };
    for (const Case& c : cases) {
        const auto path = dir / c.name;
        write(path, c.text);
        try {
            c.read(path);
            ADD_FAILURE() << c.name << " was accepted: " << c.text;
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), path.string()) << c.name;
            EXPECT_NE(e.subject().find(c.field), std::string::npos) << c.name << ": " << e.what();
        } catch (const std::exception& e) {
            ADD_FAILURE() << c.name << ": untyped exception " << e.what();
        }
    }
    // In range, and whole-valued floats, are taken as they are.
    write(dir / "ok.json", R"({"params": {"seed": 18446744073709551615, "octaves": 3.0}})");
    const auto ok = reflectance::readSidecar(dir / "ok.json");
    EXPECT_EQ(ok.params.noise.seed, 18446744073709551615ull);
    EXPECT_EQ(ok.params.noise.octaves, 3);
}

// A sidecar names its outputs; `map --from` writes them beside the sidecar
// only, never where a sidecar from elsewhere points.
TEST(JsonInput, SidecarOutputsOutsideItsFolderAreRefused) {
    test::TempDir dir;
    std::filesystem::create_directories(dir / "maps");
    std::filesystem::create_directories(dir / "victim");
    write(dir / "victim" / "notes.png", "precious");
    for (const std::string& target : {std::string("../victim/notes.png"), (dir / "victim" / "notes.png").string(),
                                      std::string("file:///tmp/x.png")}) {
        write(dir / "maps" / "m.json", R"({"params": {"size": 64}, "outputs": {"map": ")" + target + R"("}})");
        const auto r = test::runCli("map --from '" + (dir / "maps" / "m.json").string() + "'");
        EXPECT_NE(r.exitCode, 0) << target;
        EXPECT_EQ(r.err.rfind("error: field 'outputs.map' in " + (dir / "maps" / "m.json").string(), 0), 0u) << r.err;
        EXPECT_NE(r.err.find("not a file inside the sidecar's folder"), std::string::npos) << r.err;
    }
    std::ifstream in(dir / "victim" / "notes.png");
    std::string kept((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(kept, "precious");
    // Beside the sidecar (also in a subfolder of it) is fine.
    write(dir / "maps" / "m.json", R"({"params": {"size": 64}, "outputs": {"map": "out/m.png"}})");
    std::filesystem::create_directories(dir / "maps" / "out");
    const auto r = test::runCli("map --from '" + (dir / "maps" / "m.json").string() + "'");
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "maps" / "out" / "m.png"));
}

}  // namespace
}  // namespace mucosa
