// Command-line mistakes a new user makes: each is one `error:` line that names
// the command and the option at fault, a non-zero exit, and nothing written.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "cli_helpers.hpp"
#include "test_support.hpp"

namespace mucosa::test {
namespace {

TEST(CliErrors, UnknownOptionNamesTheCommandAndTheNearestOption) {
    TempDir dir;
    auto r = runCli("map -o m.png 12 --frequncy 3", dir.path());
    EXPECT_EQ(r.err, "error: unknown option '--frequncy' in mucosa map: did you mean '--frequency'?\n");
    EXPECT_NE(r.exitCode, 0);
    expectOneErrorLine(runCli("map -o m.png --frequncy=3", dir.path()), "'--frequncy' in mucosa map: did you mean");
    expectOneErrorLine(runCli("render --outptu x.png", dir.path()),
                       "unknown option '--outptu' in mucosa render: did you mean '--output'?");
    expectOneErrorLine(runCli("render -o x.png --mdoe noise", dir.path()), "did you mean '--mode'?");
    expectOneErrorLine(runCli("render -o x.png -frames 3", dir.path()), "did you mean '--frames'?");
    expectOneErrorLine(runCli("study plan --observrs 3", dir.path()),
                       "unknown option '--observrs' in mucosa study plan: did you mean '--observers'?");
    // The tool's own options count for every subcommand.
    expectOneErrorLine(runCli("phantom --quite", dir.path()), "did you mean '--quiet'?");
    EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(CliErrors, UnknownOptionFarFromEveryOptionSuggestsNothing) {
    TempDir dir;
    const auto r = runCli("render -o x.png --zzzz", dir.path());
    expectOneErrorLine(r, "unknown option '--zzzz' in mucosa render");
    EXPECT_EQ(r.err.find("did you mean"), std::string::npos) << r.err;
    // An option of another command is not close to any of this one's.
    const auto other = runCli("render -o x.png --octaves 3", dir.path());
    expectOneErrorLine(other, "unknown option '--octaves' in mucosa render");
    EXPECT_EQ(other.err.find("did you mean"), std::string::npos) << other.err;
    EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(CliErrors, UnknownCommandAndStrayArgumentsAreNamed) {
    expectOneErrorLine(runCli("rendr -o x.png"), "unknown command 'rendr': did you mean 'render'?");
    expectOneErrorLine(runCli("render -o x.png a.json b.json"), "unexpected argument 'b.json' in mucosa render");
}

TEST(CliErrors, CountOptionsStateTheirRange) {
    for (const std::string args : {"view --frames 0", "render -o x.png --frames 0", "--threads -1 phantom",
                                   "study plan --manifest m.json -o p.json --likert -1"}) {
        const auto r = runCli(args);
        expectOneErrorLine(r, "must be at least", args);
        EXPECT_EQ(r.err.find("1797693"), std::string::npos) << r.err;  // DBL_MAX written out
        EXPECT_EQ(r.err.find(".000000"), std::string::npos) << r.err;
    }
    expectOneErrorLine(runCli("view --frames 0"), "error: --frames: must be at least 1, got 0");
    expectOneErrorLine(runCli("view --frames two"), "error: --frames: 'two' is not a whole number");
    expectOneErrorLine(runCli("compare -o s.png --views 9"), "error: --views: must be at most 8, got 9");
    // A bad value of the tool's option points to the tool's help, where it is listed.
    expectOneErrorLine(runCli("--threads -1 phantom"), "(see mucosa --help)");
}

TEST(CliErrors, SizeErrorsNameTheirOwnOption) {
    TempDir dir;
    expectOneErrorLine(runCli("compare -o s.png --tile 3x3", dir.path()), "error: --tile: '3x3' is not WxH");
    expectOneErrorLine(runCli("view --window 3", dir.path()), "error: --window: '3' is not WxH");
    expectOneErrorLine(runCli("render -o f.png --size 3", dir.path()), "error: --size: '3' is not WxH");
    EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

// Commands that write into a folder create the folder but not its parents,
// as every command that writes a file requires its folder to exist.
TEST(CliErrors, OutputFoldersNeedAnExistingParent) {
    TempDir dir;
    const auto render = runCli("render -o missing/x.png", dir.path());
    expectOneErrorLine(render, "directory 'missing' does not exist");
    const std::string expected = "error: output path in missing/x: directory 'missing' does not exist\n";
    EXPECT_EQ(runCli("demo -o missing/x", dir.path()).err, expected);
    EXPECT_EQ(runCli("fit --mesh m.ply --frames f.json -o missing/x", dir.path()).err, expected);
    EXPECT_EQ(runCli("categories --mesh m.ply --fit fit --frames f.json -o missing/x", dir.path()).err, expected);
    EXPECT_EQ(runCli("study analyze r.csv -o missing/x", dir.path()).err, expected);
    EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
    // A file where the folder should be is refused too.
    { std::ofstream(dir / "file") << "x"; }
    expectOneErrorLine(runCli("demo -o file", dir.path()), "exists and is not a directory");
}

}  // namespace
}  // namespace mucosa::test
