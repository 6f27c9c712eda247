#pragma once
// SHA-256 (FIPS 180-4): the checksums of a dataset's files, in the format
// `sha256sum` reads and writes, so a user can check them without Mucosa.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

namespace mucosa {

class Sha256 {
public:
    Sha256() noexcept;
    void update(std::span<const std::byte> bytes) noexcept;
    // The digest; the object is spent afterwards.
    std::array<std::uint8_t, 32> finish() noexcept;

private:
    void block(const std::uint8_t* p) noexcept;
    std::array<std::uint32_t, 8> h_;
    std::array<std::uint8_t, 64> buffer_{};
    std::size_t used_ = 0;
    std::uint64_t length_ = 0;  // bytes
};

// The lowercase hex digest of `bytes`.
std::string sha256Hex(std::span<const std::byte> bytes);
std::string sha256Hex(std::string_view text);
// The lowercase hex digest of a file's content, read in chunks; IoError when
// it cannot be read.
std::string sha256File(const std::filesystem::path& path);

}  // namespace mucosa
