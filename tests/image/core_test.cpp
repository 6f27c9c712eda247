#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>

#include <gtest/gtest.h>

#include <mucosa/image/image.hpp>

#include "test_support.hpp"

using namespace mucosa;

TEST(Core, ErrorsFormatAsOneLine) {
    const InputError e("frequency", "map.json", "must be a positive number");
    EXPECT_STREQ(e.what(), "frequency in map.json: must be a positive number");
    EXPECT_STREQ(InputError("size", "", "must be at least 1").what(), "size: must be at least 1");
}

TEST(Core, RefusesAllocationsLargerThanAvailableMemory) {
    EXPECT_GT(availableMemoryBytes(), 1u << 20);
    // Twice what is free now, and a GiB more: tests running beside this one
    // free memory between the two reads of /proc/meminfo.
    EXPECT_THROW(requireMemory(saturatingMul(availableMemoryBytes(), 2) + (1ull << 30), "test"), ResourceError);
    EXPECT_THROW(image::Image8(1 << 20, 1 << 20, 3), ResourceError);  // 3 TiB
    try {
        requireMemory(UINT64_MAX, "a huge map");
    } catch (const ResourceError& e) {
        EXPECT_NE(std::string(e.what()).find("18446744073709551615 bytes"), std::string::npos) << e.what();
    }
    EXPECT_EQ(saturatingMul(UINT64_MAX / 2, 3), UINT64_MAX);
}

TEST(Core, AtomicFileRemovesItsTemporaryUnlessCommitted) {
    test::TempDir dir;
    {
        AtomicFile f(dir / "out.bin");
        f.write(std::string("partial"));
        EXPECT_TRUE(std::filesystem::exists(f.temporaryPath()));
    }  // not committed: as if an error had been thrown mid-write
    EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
    writeFileAtomic(dir / "out.bin", std::string("complete"));
    EXPECT_EQ(readTextFile(dir / "out.bin"), "complete");
    writeFileAtomic(dir / "out.bin", std::string("replaced"));
    EXPECT_EQ(readTextFile(dir / "out.bin"), "replaced");
    EXPECT_THROW(AtomicFile(dir / "missing" / "x"), IoError);
    EXPECT_THROW(AtomicFile(dir.path()), IoError);
}

// Big buffers come from allocateLarge: zeroed, 2 MiB aligned on Linux (so
// transparent huge pages can back them), and usable like any vector storage.
TEST(Core, LargeBuffersAreZeroedAlignedAndReleased) {
    for (int round = 0; round < 3; ++round) {
        image::ImageF big(1500, 1000, 1);  // 6 MB
        std::size_t nonzero = 0;
        for (float v : big.span()) nonzero += v != 0.0f;
        EXPECT_EQ(nonzero, 0u);
#if defined(__linux__) && !defined(__SANITIZE_ADDRESS__)  // sanitizer builds use operator new
        EXPECT_EQ(reinterpret_cast<std::uintptr_t>(big.data()) % (std::size_t{2} << 20), 0u);
#endif
        big.at(1499, 999) = 1.0f;
        image::ImageF copy = big;  // copies through the same allocator
        EXPECT_EQ(copy, big);
    }
    image::Image8 small(3, 2, 1);  // below the threshold: operator new, cache-line aligned
    EXPECT_EQ(small.at(2, 1), 0);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(small.data()) % 64, 0u);
    std::vector<int, LargeAllocator<int>> v;
    for (int i = 0; i < 1'000'000; ++i) v.push_back(i);  // grows across the threshold
    EXPECT_EQ(v[999'999], 999'999);
}
