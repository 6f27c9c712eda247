// runIsolated: whatever the work does in the child (crash, spin, allocate
// without bound, throw), the caller gets one Error naming the file, within the
// limits, and an honest result arrives byte for byte.
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>

#include "core/isolate.hpp"

namespace mucosa::test {
namespace {

using detail::IsolationLimits;
using detail::runIsolated;
using ::testing::HasSubstr;

std::string errorOf(const std::function<std::string()>& work, const IsolationLimits& limits = {}) {
    try {
        runIsolated(work, limits, "mesh", "hostile.ply");
    } catch (const InputError& e) {
        return std::string("InputError: ") + e.what();
    } catch (const Error& e) {
        return std::string("Error: ") + e.what();
    }
    return "no error";
}

TEST(Isolate, ResultArrivesByteForByte) {
    std::string big(40u << 20, '\0');
    for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>((i * 2654435761u) >> 13);
    const std::string got = runIsolated([&] { return big; }, {}, "mesh", "a.ply");
    EXPECT_EQ(got.size(), big.size());
    EXPECT_TRUE(got == big);
    EXPECT_EQ(runIsolated([] { return std::string(); }, {}, "mesh", "a.ply"), "");
}

TEST(Isolate, ChildStateDoesNotReachTheCaller) {
    int counter = 0;
    runIsolated(
        [&] {
            counter = 42;
            return std::string("x");
        },
        {}, "mesh", "a.ply");
    EXPECT_EQ(counter, 0);
}

TEST(Isolate, CrashBecomesAnInputErrorNamingTheFile) {
    const std::string what = errorOf([]() -> std::string {
        std::raise(SIGSEGV);
        return "unreachable";
    });
    EXPECT_THAT(what, HasSubstr("InputError: mesh in hostile.ply"));
    EXPECT_THAT(what, HasSubstr("crashed"));
    EXPECT_THAT(what, HasSubstr("signal 11"));
    EXPECT_THAT(errorOf([]() -> std::string { std::abort(); }), HasSubstr("signal 6"));
}

TEST(Isolate, SpinningChildIsStoppedAtTheCpuLimit) {
    IsolationLimits limits;
    limits.cpuSeconds = 1;
    limits.wallSeconds = 10;
    const auto start = std::chrono::steady_clock::now();
    const std::string what = errorOf(
        []() -> std::string {
            for (;;) asm volatile("");
        },
        limits);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_THAT(what, HasSubstr("InputError: mesh in hostile.ply"));
    EXPECT_THAT(what, HasSubstr("s of CPU"));
    EXPECT_LT(seconds, 8.0);
}

TEST(Isolate, SleepingChildIsStoppedAtTheWallDeadline) {
    IsolationLimits limits;
    limits.wallSeconds = 0.5;
    const auto start = std::chrono::steady_clock::now();
    const std::string what = errorOf(
        []() -> std::string {
            // A hang that uses no CPU (and ignores SIGTERM, as Assimp's PLY hang does).
            std::signal(SIGTERM, SIG_IGN);
            for (;;) ::pause();
        },
        limits);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_THAT(what, HasSubstr("did not finish within 0.5 s"));
    EXPECT_LT(seconds, 5.0);
}

TEST(Isolate, MemoryExhaustionIsStoppedAtTheLimit) {
    IsolationLimits limits;
    limits.memoryBytes = 256ull << 20;
    const std::string what = errorOf(
        []() -> std::string {
            // Touch every page so the resident set grows (ASan builds have no
            // address-space limit; the parent's watchdog catches them).
            std::vector<std::vector<char>> hoard;
            for (int i = 0; i < 64; ++i) {
                hoard.emplace_back(64u << 20);
                std::memset(hoard.back().data(), 1, hoard.back().size());
            }
            return std::to_string(hoard.size());
        },
        limits);
    EXPECT_THAT(what, HasSubstr("InputError: mesh in hostile.ply"));
    EXPECT_THAT(what, ::testing::AnyOf(HasSubstr("memory"), HasSubstr("signal 9")));
}

// A caller with a large resident set (a simulator with its textures loaded)
// is not mistaken for a child over its limit: the child starts with the
// caller's pages, and only what it adds counts.
TEST(Isolate, CallersOwnMemoryDoesNotCountAgainstTheChild) {
    std::vector<char> held(512u << 20);
    std::memset(held.data(), 1, held.size());
    IsolationLimits limits;
    limits.memoryBytes = 64ull << 20;
    // The child lives 200 ms, so the 20 ms watchdog sees it several times.
    const auto slowOk = [] {
        ::usleep(200000);
        return std::string("ok");
    };
    EXPECT_EQ(runIsolated(slowOk, limits, "mesh", "a.ply"), "ok");
    EXPECT_EQ(held[12345], 1);
}

TEST(Isolate, OversizedResultIsRefused) {
    IsolationLimits limits;
    limits.maxResultBytes = 1 << 20;
    EXPECT_THAT(errorOf([] { return std::string(4u << 20, 'x'); }, limits), HasSubstr("result is larger"));
}

TEST(Isolate, ErrorsThrownInTheChildKeepTheirKindAndText) {
    try {
        runIsolated([]() -> std::string { throw IoError("buffer", "b.bin", "no such file"); }, {}, "mesh", "a.gltf");
        FAIL() << "no error";
    } catch (const IoError& e) {
        EXPECT_EQ(e.subject(), "buffer");
        EXPECT_EQ(e.file(), "b.bin");
        EXPECT_EQ(e.reason(), "no such file");
    }
    EXPECT_THROW(runIsolated([]() -> std::string { throw ResourceError("x", "y", "z"); }, {}, "mesh", "a"),
                 ResourceError);
    EXPECT_THAT(errorOf([]() -> std::string { throw std::runtime_error("Assimp: bad header"); }),
                HasSubstr("Assimp: bad header"));
    EXPECT_THAT(errorOf([]() -> std::string { throw std::bad_alloc(); }), HasSubstr("ran out of memory"));
}

}  // namespace
}  // namespace mucosa::test
