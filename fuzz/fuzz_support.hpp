#pragma once
// Shared by the libFuzzer harnesses (fuzz/*.cpp). The property every harness
// checks: on any input the parser either succeeds or throws a typed
// mucosa::Error (InputError, IoError, ResourceError) — never crashes, hangs,
// exhausts memory (libFuzzer's -rss_limit_mb / -malloc_limit_mb catch it),
// trips a sanitizer, or lets another exception (std::bad_alloc, a raw
// nlohmann exception, InternalError) escape.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include <mucosa/core/error.hpp>

namespace mucosa::fuzz {

// A per-process scratch folder (on tmpfs when there is one), removed at exit.
inline const std::filesystem::path& scratchDir() {
    static const std::filesystem::path dir = [] {
        std::error_code ec;
        std::filesystem::path base = std::filesystem::exists("/dev/shm", ec) ? std::filesystem::path("/dev/shm")
                                                                             : std::filesystem::temp_directory_path();
        auto d = base / ("mucosa-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(d);
        static struct Cleanup {
            std::filesystem::path p;
            ~Cleanup() {
                std::error_code e;
                std::filesystem::remove_all(p, e);
            }
        } cleanup{d};
        return d;
    }();
    return dir;
}

// Writes the input to scratchDir()/name and returns the path.
inline std::filesystem::path writeInput(const std::uint8_t* data, std::size_t size, const std::string& name) {
    const auto path = scratchDir() / name;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    out.close();
    if (!out) {
        std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
        std::abort();
    }
    return path;
}

// Runs f(); a typed mucosa::Error is an accepted outcome, anything else aborts
// (libFuzzer then saves the input as a crash).
template <class F>
int guarded(F&& f) {
    try {
        f();
    } catch (const mucosa::Error&) {
        // rejected cleanly: the contract
    } catch (const std::exception& e) {
        std::fprintf(stderr, "fuzz: untyped exception escaped: %s\n", e.what());
        std::abort();
    } catch (...) {
        std::fprintf(stderr, "fuzz: unknown exception escaped\n");
        std::abort();
    }
    return 0;
}

}  // namespace mucosa::fuzz
