// SHA-256 against FIPS 180-4's examples and coreutils' sha256sum.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include <mucosa/core/checksum.hpp>
#include <mucosa/core/error.hpp>

namespace mucosa {
namespace {

std::string digest(const std::string& s) {
    return sha256Hex(std::as_bytes(std::span(s.data(), s.size())));
}

TEST(Sha256, MatchesTheStandardsExamples) {
    EXPECT_EQ(digest(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    EXPECT_EQ(digest("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    // Two blocks: the padding spills into a second one.
    EXPECT_EQ(digest("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
              "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
    EXPECT_EQ(digest(std::string(1000000, 'a')), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256, AnyChunkingGivesTheSameDigest) {
    std::string s;
    for (int i = 0; i < 1000; ++i) s += static_cast<char>((i * 7919) & 0xff);
    const std::string whole = digest(s);
    for (std::size_t step : {1u, 3u, 55u, 56u, 63u, 64u, 65u, 127u}) {
        Sha256 h;
        for (std::size_t at = 0; at < s.size(); at += step)
            h.update(std::as_bytes(std::span(s.data() + at, std::min(step, s.size() - at))));
        const auto d = h.finish();
        std::string hex;
        for (auto b : d) {
            static const char* digits = "0123456789abcdef";
            hex += digits[b >> 4];
            hex += digits[b & 15];
        }
        EXPECT_EQ(hex, whole) << "chunks of " << step;
    }
}

TEST(Sha256, AFilesDigestIsSha256sums) {
    const auto dir = std::filesystem::temp_directory_path() / ("mucosa_sha_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const auto file = dir / "data.bin";
    {
        std::ofstream out(file, std::ios::binary);
        for (int i = 0; i < 3 << 20; ++i) out.put(static_cast<char>((i * 31 + (i >> 11)) & 0xff));
    }
    const std::string cmd = "sha256sum '" + file.string() + "' > '" + (dir / "sum.txt").string() + "'";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    std::ifstream in(dir / "sum.txt");
    std::string expected;
    in >> expected;
    EXPECT_EQ(sha256File(file), expected);
    EXPECT_THROW(sha256File(dir / "missing.bin"), IoError);
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mucosa
