#pragma once
// Refuse requests that would exhaust memory before allocating anything.
#include <cstddef>
#include <cstdint>
#include <new>
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

// Storage for big buffers (images, encoded files). Requests of 2 MiB and more
// are mapped directly, 2 MiB aligned and marked for transparent huge pages
// where the kernel offers them (Linux madvise mode), so a 64 MiB image costs
// 32 page faults instead of 16 384; smaller ones come from operator new,
// 64-byte (cache-line) aligned.
// Mapped memory arrives zeroed. Throws std::bad_alloc when the system refuses.
// (AddressSanitizer builds use operator new throughout, so ASan sees them.)
void* allocateLarge(std::size_t bytes);
void deallocateLarge(void* p, std::size_t bytes) noexcept;

template <class T>
struct LargeAllocator {
    using value_type = T;
    LargeAllocator() = default;
    template <class U>
    LargeAllocator(const LargeAllocator<U>&) noexcept {}
    T* allocate(std::size_t n) {
        if (n > static_cast<std::size_t>(-1) / sizeof(T)) throw std::bad_array_new_length();
        return static_cast<T*>(allocateLarge(n * sizeof(T)));
    }
    void deallocate(T* p, std::size_t n) noexcept { deallocateLarge(p, n * sizeof(T)); }
    template <class U>
    bool operator==(const LargeAllocator<U>&) const noexcept {
        return true;
    }
};

}  // namespace mucosa
