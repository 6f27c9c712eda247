#include <mucosa/reflectance/tissue_texture.hpp>

#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

#include <mucosa/core/error.hpp>
#include <mucosa/noise/fractal.hpp>

namespace mucosa::reflectance {

image::Image8 tissueTexture(int size, std::uint64_t seed) {
    MUCOSA_CHECK(size >= 8, "texture size must be at least 8");
    const std::size_t n = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    std::vector<float> mottle(n), vessels(n);
    noise::FractalParams m;
    m.frequency = 6;
    m.octaves = 5;
    m.seed = seed;
    m.tileable = true;
    m.z = 0.37;
    noise::fillFractal(m, std::span<float>(mottle), size, size);
    noise::FractalParams v = m;
    v.frequency = 3;
    v.octaves = 4;
    v.gain = 0.45;
    v.z = 0.71;
    noise::fillFractal(v, std::span<float>(vessels), size, size);
    image::Image8 img(size, size, 3);
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * size + x;
            const float shade = 0.92f + 0.16f * mottle[i];
            // Vessels: thin ridges where the noise crosses zero.
            const float ridge = std::max(0.0f, 1.0f - std::abs(vessels[i]) * 9.0f);
            const float vessel = ridge * ridge;
            const float r = shade * (1.0f - 0.12f * vessel), g = shade * (1.0f - 0.45f * vessel),
                        b = shade * (1.0f - 0.40f * vessel);
            img.at(x, y, 0) = static_cast<std::uint8_t>(std::lround(std::clamp(r, 0.0f, 1.0f) * 255.0f));
            img.at(x, y, 1) = static_cast<std::uint8_t>(std::lround(std::clamp(g, 0.0f, 1.0f) * 255.0f));
            img.at(x, y, 2) = static_cast<std::uint8_t>(std::lround(std::clamp(b, 0.0f, 1.0f) * 255.0f));
        }
    return img;
}

}  // namespace mucosa::reflectance
