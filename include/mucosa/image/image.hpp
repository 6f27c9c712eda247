#pragma once
// Image buffers: interleaved channels, row-major, first row = top of the file
// (v = 0 of the texture, see docs/theory.md "Conventions").
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <mucosa/core/memory.hpp>

namespace mucosa::image {

template <class T>
class Image {
public:
    Image() = default;
    // Throws ResourceError if the buffer would not fit in available memory.
    Image(int width, int height, int channels);

    int width() const noexcept { return width_; }
    int height() const noexcept { return height_; }
    int channels() const noexcept { return channels_; }
    bool empty() const noexcept { return data_.empty(); }
    std::size_t size() const noexcept { return data_.size(); }

    T* data() noexcept { return data_.data(); }
    const T* data() const noexcept { return data_.data(); }
    std::span<T> span() noexcept { return data_; }
    std::span<const T> span() const noexcept { return data_; }
    T* row(int y) noexcept { return data_.data() + static_cast<std::size_t>(y) * rowStride(); }
    const T* row(int y) const noexcept { return data_.data() + static_cast<std::size_t>(y) * rowStride(); }
    std::size_t rowStride() const noexcept {
        return static_cast<std::size_t>(width_) * static_cast<std::size_t>(channels_);
    }
    T& at(int x, int y, int c = 0) noexcept { return row(y)[static_cast<std::size_t>(x) * channels_ + c]; }
    const T& at(int x, int y, int c = 0) const noexcept { return row(y)[static_cast<std::size_t>(x) * channels_ + c]; }

    bool operator==(const Image&) const = default;

private:
    int width_ = 0, height_ = 0, channels_ = 0;
    std::vector<T, LargeAllocator<T>> data_;  // big images: huge pages (core/memory.hpp)
};

using Image8 = Image<std::uint8_t>;
using Image16 = Image<std::uint16_t>;
using ImageF = Image<float>;
using ImageD = Image<double>;

// Bytes an image of this shape needs (saturating, for memory checks).
std::uint64_t imageBytes(int width, int height, int channels, std::size_t bytesPerSample) noexcept;

extern template class Image<std::uint8_t>;
extern template class Image<std::uint16_t>;
extern template class Image<float>;
extern template class Image<double>;

}  // namespace mucosa::image
