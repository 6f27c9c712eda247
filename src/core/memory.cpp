#include <mucosa/core/memory.hpp>

#include <sys/mman.h>
#include <sys/resource.h>

#include <cstdint>
#include <new>

#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>

namespace mucosa {

std::uint64_t availableMemoryBytes() {
    std::uint64_t avail = std::numeric_limits<std::uint64_t>::max();
    std::ifstream meminfo("/proc/meminfo");
    std::string key;
    std::uint64_t kib = 0;
    std::string unit;
    while (meminfo >> key >> kib) {
        std::getline(meminfo, unit);
        if (key == "MemAvailable:") {
            avail = kib * 1024;
            break;
        }
    }
    for (int resource : {RLIMIT_AS, RLIMIT_DATA}) {
        rlimit lim{};
        if (getrlimit(resource, &lim) == 0 && lim.rlim_cur != RLIM_INFINITY)
            avail = std::min<std::uint64_t>(avail, lim.rlim_cur);
    }
    return avail;
}

std::uint64_t saturatingMul(std::uint64_t a, std::uint64_t b) noexcept {
    if (a != 0 && b > std::numeric_limits<std::uint64_t>::max() / a) return std::numeric_limits<std::uint64_t>::max();
    return a * b;
}

std::string formatBytes(std::uint64_t bytes) {
    if (bytes == std::numeric_limits<std::uint64_t>::max()) return "more than 16 EiB";
    const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    double v = static_cast<double>(bytes);
    int u = 0;
    while (v >= 1024.0 && u < 6) {
        v /= 1024.0;
        ++u;
    }
    return u == 0 ? fmt::format("{} B", bytes) : fmt::format("{:.1f} {}", v, units[u]);
}

void requireMemory(std::uint64_t bytes, const std::string& what) {
    const std::uint64_t avail = availableMemoryBytes();
    if (bytes > avail) {
        throw ResourceError(what, "",
                            fmt::format("needs {} bytes ({}) but only {} are available", bytes, formatBytes(bytes),
                                        formatBytes(avail)));
    }
}

// Below the mapping threshold: cache-line aligned, for vector loops.
constexpr std::size_t kSmallAlignment = 64;

// Sanitizer builds take everything from operator new, so that AddressSanitizer
// watches big buffers too.
#if defined(__linux__) && defined(MADV_HUGEPAGE) && !defined(__SANITIZE_ADDRESS__)
#define MUCOSA_MAP_LARGE 1
namespace {

constexpr std::size_t kHugePage = std::size_t{2} << 20;

std::size_t mappedBytes(std::size_t bytes) noexcept {
    return (bytes + kHugePage - 1) / kHugePage * kHugePage;
}

}  // namespace
#endif

void* allocateLarge(std::size_t bytes) {
#ifdef MUCOSA_MAP_LARGE
    if (bytes >= kHugePage) {
        if (bytes > static_cast<std::size_t>(-1) - 2 * kHugePage) throw std::bad_alloc();
        // Map one huge page more than needed and trim to a 2 MiB boundary.
        const std::size_t size = mappedBytes(bytes), span = size + kHugePage;
        void* raw = mmap(nullptr, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (raw == MAP_FAILED) throw std::bad_alloc();
        const auto base = reinterpret_cast<std::uintptr_t>(raw);
        const std::uintptr_t aligned = (base + kHugePage - 1) & ~static_cast<std::uintptr_t>(kHugePage - 1);
        if (aligned > base) munmap(raw, aligned - base);
        const std::size_t tail = (base + span) - (aligned + size);
        if (tail > 0) munmap(reinterpret_cast<void*>(aligned + size), tail);
        void* p = reinterpret_cast<void*>(aligned);
        madvise(p, size, MADV_HUGEPAGE);  // advice only: ignored where THP is off
        return p;
    }
#endif
    return ::operator new (bytes, std::align_val_t{kSmallAlignment});
}

void deallocateLarge(void* p, std::size_t bytes) noexcept {
    if (!p) return;
#ifdef MUCOSA_MAP_LARGE
    if (bytes >= kHugePage) {
        munmap(p, mappedBytes(bytes));
        return;
    }
#else
    (void)bytes;
#endif
    ::operator delete (p, std::align_val_t{kSmallAlignment});
}

}  // namespace mucosa
