#include <mucosa/core/memory.hpp>

#include <sys/resource.h>

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

}  // namespace mucosa
