#include <mucosa/image/image.hpp>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>

namespace mucosa::image {

std::uint64_t imageBytes(int width, int height, int channels, std::size_t bytesPerSample) noexcept {
    if (width <= 0 || height <= 0 || channels <= 0) return 0;
    return saturatingMul(saturatingMul(saturatingMul(static_cast<std::uint64_t>(width), height), channels),
                         bytesPerSample);
}

template <class T>
Image<T>::Image(int width, int height, int channels) : width_(width), height_(height), channels_(channels) {
    if (width < 1 || height < 1 || channels < 1 || channels > 4)
        throw InputError("image size", "", fmt::format("{}x{}x{} is not a valid image", width, height, channels));
    requireMemory(imageBytes(width, height, channels, sizeof(T)), fmt::format("a {}x{} image", width, height));
    data_.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
                 static_cast<std::size_t>(channels));
}

template class Image<std::uint8_t>;
template class Image<std::uint16_t>;
template class Image<float>;
template class Image<double>;

}  // namespace mucosa::image
