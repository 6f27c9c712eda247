// The one rule for "a file may only name files beside it", the disk check
// before long runs, whole numbers from JSON taken whole or refused, and the
// line and column of a JSON syntax error.
#include <cstdint>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

#include "core/json_parse.hpp"
#include "test_support.hpp"

namespace mucosa::test {
namespace {

TEST(ConfinedPath, RelativePathsBelowTheFolderOnly) {
    TempDir dir;
    std::filesystem::create_directories(dir / "model" / "sub");
    std::filesystem::create_directories(dir / "outside");
    const auto folder = dir / "model";
    EXPECT_EQ(confinedPath(folder, "a.bin"), folder / "a.bin");
    EXPECT_EQ(confinedPath(folder, "sub/a.bin"), folder / "sub/a.bin");
    EXPECT_TRUE(confinedPath(folder, "sub/../a.bin"));  // stays inside
    EXPECT_TRUE(confinedPath(folder, "not-yet/created/a.bin"));
    for (const char* bad : {"../outside/a.bin", "sub/../../outside/a.bin", "/etc/passwd", "file:///etc/passwd",
                            "C:/Windows/x", "http://127.0.0.1/x", "", "\\\\server\\share"})
        EXPECT_FALSE(confinedPath(folder, bad)) << bad;
    // A symlink inside that points outside does not count as inside.
    std::ofstream(dir / "outside" / "secret") << "x";
    std::filesystem::create_symlink(dir / "outside" / "secret", folder / "link");
    std::filesystem::create_directory_symlink(dir / "outside", folder / "dirlink");
    EXPECT_FALSE(confinedPath(folder, "link"));
    EXPECT_FALSE(confinedPath(folder, "dirlink/secret"));
    EXPECT_TRUE(resolvesInside(folder, folder));
    EXPECT_FALSE(resolvesInside(folder, dir.path()));
}

TEST(Disk, RequireDiskRefusesWhatWillNotFit) {
    TempDir dir;
    const std::uint64_t free = availableDiskBytes(dir / "does/not/exist/yet.png");  // nearest existing parent
    EXPECT_GT(free, 0u);
    EXPECT_NO_THROW(requireDisk(1, dir / "f.png", "a frame"));
    try {
        requireDisk(free + (1ull << 40), dir / "f.png", "1000 frames");
        FAIL() << "not refused";
    } catch (const ResourceError& e) {
        EXPECT_EQ(e.subject(), "1000 frames");
        EXPECT_NE(e.reason().find("of disk but only"), std::string::npos) << e.what();
    }
}

// A bare file name ("fly.png", as `mucosa render -o fly.png` gives it) is in
// the working folder: its free space is the working folder's.
TEST(Disk, ABareFileNameIsInTheWorkingFolder) {
    const auto here = std::filesystem::current_path();
    TempDir dir;
    std::filesystem::current_path(dir.path());
    std::uint64_t bare = 0, dot = 0;
    EXPECT_NO_THROW(bare = availableDiskBytes("fly.png"));
    dot = availableDiskBytes(".");
    std::filesystem::current_path(here);
    EXPECT_GT(bare, 0u);
    EXPECT_NEAR(static_cast<double>(bare), static_cast<double>(dot), 64.0 * 1024 * 1024);  // the same file system
}

TEST(WholeNumber, TakenWholeOrRefused) {
    using detail::wholeNumber;
    using nlohmann::json;
    EXPECT_EQ(wholeNumber<int>(json::parse("7"), "f", "x.json"), 7);
    EXPECT_EQ(wholeNumber<int>(json::parse("-7"), "f", "x.json"), -7);
    EXPECT_EQ(wholeNumber<int>(json::parse("3.0"), "f", "x.json"), 3);
    EXPECT_EQ(wholeNumber<std::uint64_t>(json::parse("18446744073709551615"), "f", "x.json"), UINT64_MAX);
    EXPECT_EQ(wholeNumber<std::int64_t>(json::parse("-9223372036854775808"), "f", "x.json"), INT64_MIN);
    for (const char* bad : {"4294967297", "-4294967295", "2147483648", "2.5", "1e300", "\"3\"", "true", "null"})
        EXPECT_THROW(wholeNumber<int>(json::parse(bad), "f", "x.json"), InputError) << bad;
    EXPECT_THROW(wholeNumber<std::uint32_t>(json::parse("-1"), "f", "x.json"), InputError);
    EXPECT_THROW(wholeNumber<int>(json::parse("9"), "f", "x.json", 1, 8), InputError);
    try {
        wholeNumber<int>(json::parse("4294967297"), "likert", "answers.json", 1, 5);
        FAIL();
    } catch (const InputError& e) {
        EXPECT_EQ(e.subject(), "field 'likert'");
        EXPECT_EQ(e.file(), "answers.json");
        EXPECT_EQ(e.reason(), "4294967297 is out of range [1, 5]");
    }
}

// Lines and columns count from 1, as editors do; a column counts UTF-8
// characters; an offset past the end is just after the last character.
TEST(JsonParse, LineAndColumnOfAByteOffset) {
    using detail::lineAndColumn;
    EXPECT_EQ(lineAndColumn("{}", 0), std::make_pair(1, 1));
    EXPECT_EQ(lineAndColumn("{}", 1), std::make_pair(1, 2));
    EXPECT_EQ(lineAndColumn("{\n}", 2), std::make_pair(2, 1));
    EXPECT_EQ(lineAndColumn("{\r\n  x", 5), std::make_pair(2, 3));
    EXPECT_EQ(lineAndColumn("{\"\xc3\xa9\xc3\xa9\": x", 9), std::make_pair(1, 8));  // {"éé": x -> x is column 8
    EXPECT_EQ(lineAndColumn("{\n\n", 99), std::make_pair(3, 1));
    EXPECT_EQ(lineAndColumn("", 0), std::make_pair(1, 1));
}

TEST(JsonParse, SyntaxErrorIsAtTheOffendingCharacter) {
    try {
        (void)detail::parseJsonFile("{\n  \"a\": 1,\n}", "x.json");
        ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), 3);
        EXPECT_EQ(e.column(), 1);
        EXPECT_EQ(e.subject(), "JSON");
        EXPECT_EQ(e.file(), "x.json");
        EXPECT_EQ(std::string(e.what()).rfind("x.json:3:1: JSON: syntax error", 0), 0u) << e.what();
    }
    // Past the end (an unterminated object): the line after the last newline.
    try {
        (void)detail::parseJsonFile("{\"a\": 1\n", "y.json");
        ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), 2);
        EXPECT_EQ(e.column(), 1);
    }
}

// What a process killed mid-write leaves: `.<name>.tmp-XXXXXX`. Only those
// of the names given go.
TEST(AtomicFile, StaleTemporariesOfTheNamedFilesAreRemoved) {
    TempDir dir;
    for (const char* n : {".a.png.tmp-Ab3dE9", ".a.png.tmp-Zz9aaa", ".b.png.tmp-Ab3dE9", ".a.png.tmp-abc", "a.png",
                          ".a.png", "x.a.png.tmp-Ab3dE9"})
        std::ofstream(dir / n) << "x";
    EXPECT_EQ(removeStaleTemporaries({dir / "a.png", dir / "c.png"}), 2u);
    for (const char* kept : {".b.png.tmp-Ab3dE9", ".a.png.tmp-abc", "a.png", ".a.png", "x.a.png.tmp-Ab3dE9"})
        EXPECT_TRUE(std::filesystem::exists(dir / kept)) << kept;
    EXPECT_FALSE(std::filesystem::exists(dir / ".a.png.tmp-Ab3dE9"));
    // A real writer's temporary, left by a destructor that never ran.
    auto* leaked = new AtomicFile(dir / "b.png");
    leaked->write(std::string("half"));
    const auto tmp = leaked->temporaryPath();
    EXPECT_EQ(removeStaleTemporaries({dir / "b.png"}), 2u);
    EXPECT_FALSE(std::filesystem::exists(tmp));
    delete leaked;  // its own removal finds nothing
    EXPECT_EQ(removeStaleTemporaries({dir / "missing" / "b.png"}), 0u);
}

}  // namespace
}  // namespace mucosa::test
