#pragma once
// Refuse requests that would exhaust memory before allocating anything.
#include <cstdint>
#include <string>

namespace mucosa {

// Physical memory the process may still use: MemAvailable from /proc/meminfo,
// further limited by RLIMIT_AS / RLIMIT_DATA when they are set.
std::uint64_t availableMemoryBytes();

// Throws ResourceError("<what>", "", "needs N bytes (X GiB) but only M are available")
// when `bytes` exceeds the available memory (or overflowed: pass UINT64_MAX).
void requireMemory(std::uint64_t bytes, const std::string& what);

// Multiplies sizes, saturating at UINT64_MAX instead of wrapping.
std::uint64_t saturatingMul(std::uint64_t a, std::uint64_t b) noexcept;

// "1.5 GiB" style formatting for messages.
std::string formatBytes(std::uint64_t bytes);

}  // namespace mucosa
