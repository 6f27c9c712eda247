// PNG decoding (maps, stimuli, frames): decodePng on arbitrary bytes.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <mucosa/image/png.hpp>

#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return mucosa::fuzz::guarded([&] {
        std::vector<std::byte> bytes(reinterpret_cast<const std::byte*>(data),
                                     reinterpret_cast<const std::byte*>(data) + size);
        const auto png = mucosa::image::decodePng(bytes, "fuzz.png");
        (void)mucosa::image::to8(png);
    });
}
