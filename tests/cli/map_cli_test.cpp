// The mucosa tool as a user runs it: outputs, messages, exit codes.
#include <algorithm>
#include <cstdio>

#include <gtest/gtest.h>

#include "test_support.hpp"

using mucosa::test::readBytes;
using mucosa::test::runCli;
using mucosa::test::TempDir;

namespace {

int lineCount(const std::string& s) {
    return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
}

std::vector<std::string> listDir(const std::filesystem::path& p) {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(p)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

// A failed command prints exactly one `error: ...` line, exits non-zero and
// leaves nothing behind in `dir`.
void expectCleanFailure(const std::string& args, const TempDir& dir, const std::string& mentions) {
    const auto r = runCli(args, dir.path());
    EXPECT_NE(r.exitCode, 0) << args;
    EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << args << "\n" << r.err;
    EXPECT_EQ(lineCount(r.err), 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(mentions), std::string::npos) << args << "\n" << r.err;
    EXPECT_TRUE(listDir(dir.path()).empty()) << args << ": left files behind";
}

}  // namespace

TEST(MapCli, WritesMapSidecarAndHeight) {
    TempDir dir;
    const auto r = runCli("map -o map.png --size 128 --preset serosa --height-out h.exr --bits 16", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(listDir(dir.path()), (std::vector<std::string>{"h.exr", "map.json", "map.png"}));
    EXPECT_NE(r.out.find("map.png"), std::string::npos);
}

TEST(MapCli, FromSidecarRegeneratesIdenticalBytes) {
    TempDir dir;
    ASSERT_EQ(
        runCli("map -o a.png --size 200 --frequency 5 --octaves 4 --seed 9 --turbulence --tileable --strength 0.02",
               dir.path())
            .exitCode,
        0);
    ASSERT_EQ(runCli("map --from a.json -o b.png", dir.path()).exitCode, 0);
    EXPECT_EQ(readBytes(dir / "a.png"), readBytes(dir / "b.png"));
    // Options given with --from override the sidecar.
    ASSERT_EQ(runCli("map --from a.json -o c.png --seed 10", dir.path()).exitCode, 0);
    EXPECT_NE(readBytes(dir / "a.png"), readBytes(dir / "c.png"));
    // Without -o it rewrites the map the sidecar names, identically.
    const std::string before = readBytes(dir / "a.png");
    ASSERT_EQ(runCli("map --from a.json", dir.path()).exitCode, 0);
    EXPECT_EQ(readBytes(dir / "a.png"), before);
}

TEST(MapCli, BadInputGivesOneErrorLineAndNoFile) {
    TempDir dir;
    expectCleanFailure("map -o m.png --size 0", dir, "size");
    expectCleanFailure("map -o m.png --size -5", dir, "size");
    expectCleanFailure("map -o m.png --frequency nan", dir, "frequency");
    expectCleanFailure("map -o m.png --frequency -3", dir, "frequency");
    expectCleanFailure("map -o m.png --octaves 0", dir, "octaves");
    expectCleanFailure("map -o m.png --bits 12", dir, "bits");
    expectCleanFailure("map -o m.png --preset liver", dir, "liver");
    expectCleanFailure("map -o m.png --size 1000000", dir, "bytes");  // needs terabytes: refused up front
    expectCleanFailure("map -o no/such/dir/m.png --size 16", dir, "no/such/dir");
    expectCleanFailure("map -o m.jpg --size 16", dir, "m.jpg");
    expectCleanFailure("map -o m.png --size 16 --height-out h.tiff", dir, "h.tiff");
    expectCleanFailure("map -o m.png --tileable --frequency 2.5", dir, "frequency");
    expectCleanFailure("map --from missing.json", dir, "missing.json");
    expectCleanFailure("map", dir, "-o");
    expectCleanFailure("map -o m.png --no-such-option", dir, "no-such-option");
    std::filesystem::create_directories(dir / "ro");
    std::filesystem::permissions(dir / "ro", std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec);
    if (::geteuid() != 0) {  // root writes anywhere; the permission case only holds for users
        const auto r = runCli("map -o ro/m.png --size 16", dir.path());
        EXPECT_NE(r.exitCode, 0);
    }
    std::filesystem::remove(dir / "ro");
}

TEST(MapCli, WarnsAboutUnresolvableOctavesAndSaysHowMany) {
    TempDir dir;
    const auto r = runCli("map -o m.png --size 64 --frequency 8 --octaves 6", dir.path());
    EXPECT_EQ(r.exitCode, 0);
    EXPECT_NE(r.err.find("warning: octaves: only 3 of 6"), std::string::npos) << r.err;
}

TEST(MapCli, BadSidecarNamesTheField) {
    TempDir dir;
    { std::ofstream(dir / "s.json") << R"({"params": {"size": 64, "octaves": "many"}})"; }
    const auto r = runCli("map --from s.json -o m.png", dir.path());
    EXPECT_NE(r.exitCode, 0);
    EXPECT_NE(r.err.find("field 'octaves'"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "m.png"));
}

TEST(DemoCli, WritesTheReflectanceAndHeightMapsIntoOut) {
    TempDir dir;
    const auto r = runCli("demo --patient-frames 0", dir.path());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / "reflectance_map.png"));
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / "height.png"));
    EXPECT_NE(r.out.find((dir / "out" / "reflectance_map.png").string()), std::string::npos) << r.out;
}

TEST(Cli, EverySubcommandHasHelpAndTheToolHasAVersion) {
    const auto top = runCli("--help");
    ASSERT_EQ(top.exitCode, 0);
    // Subcommand names are the indented words under "Subcommands:".
    const auto at = top.out.find("Subcommands:");
    ASSERT_NE(at, std::string::npos);
    std::istringstream lines(top.out.substr(at));
    std::string line;
    std::getline(lines, line);
    int n = 0;
    while (std::getline(lines, line)) {
        std::istringstream words(line);
        std::string name;
        if (!(words >> name)) continue;
        const auto r = runCli(name + " --help");
        EXPECT_EQ(r.exitCode, 0) << name;
        EXPECT_FALSE(r.out.empty()) << name;
        ++n;
    }
    EXPECT_GE(n, 2);
    const auto v = runCli("--version");
    EXPECT_EQ(v.exitCode, 0);
    EXPECT_NE(v.out.find("0."), std::string::npos);
}
