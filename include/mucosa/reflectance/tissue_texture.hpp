#pragma once
// A subject texture for scenes without a real one.
#include <cstdint>

#include <mucosa/image/image.hpp>

namespace mucosa::reflectance {

// A tileable subject texture for scenes without a real one: mottled tissue
// with faint, darker vessels (fractal noise, turbulence for the vessels),
// roughly neutral so material.base_color sets the hue. RGB, size x size.
image::Image8 tissueTexture(int size, std::uint64_t seed = 7);

}  // namespace mucosa::reflectance
