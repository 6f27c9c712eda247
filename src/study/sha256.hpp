#pragma once
// SHA-256 (FIPS 180-4, core/checksum.hpp), for looking observer tokens up by their hash: the
// lookup's timing then depends on the hash, never on how much of a secret a
// guess got right.
#include <array>
#include <cstdint>
#include <span>
#include <string_view>

#include <mucosa/core/checksum.hpp>

namespace mucosa::study::detail {

inline std::array<std::uint8_t, 32> sha256(std::string_view data) {
    Sha256 h;
    h.update(std::as_bytes(std::span(data.data(), data.size())));
    return h.finish();
}

// Equal bytes, in time independent of where they differ.
template <std::size_t N>
bool constantTimeEqual(const std::array<std::uint8_t, N>& a, const std::array<std::uint8_t, N>& b) {
    std::uint8_t diff = 0;
    for (std::size_t i = 0; i < N; ++i) diff |= static_cast<std::uint8_t>(a[i] ^ b[i]);
    return diff == 0;
}

}  // namespace mucosa::study::detail
