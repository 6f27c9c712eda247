#pragma once
// Mip levels of a reflectance map for specular anti-aliasing (Toksvig 2005,
// "Mipmapping normal maps", JGT 10(3)): a distant pixel covers many texels,
// whose normals average to a shorter vector Na; Toksvig's slope variance
// sigma^2 = (1 - |Na|) / |Na| widens the highlight lobe so that the pixel
// reflects what its texels would have reflected together, instead of one
// sharp, too-bright highlight from the renormalised average (or, without
// mipmaps, a sparkle that changes with every sub-pixel motion).
//
// 8-bit RGB cannot carry |Na| (quantisation alone shortens a unit normal by
// up to 0.7 %, which Toksvig would read as roughness), so the averages are
// taken here in float from the unit normals of level 0 and the variance is
// stored explicitly: rgb = 0.5 normalize(Na) + 0.5, alpha = sigma / 0.5
// (kMapSigmaMax in shaders/common_shading.glsl). Why Toksvig rather than LEAN
// mapping: docs/theory.md, "Specular anti-aliasing".
#include <vector>

#include <mucosa/image/image.hpp>

namespace mucosa::reflectance {

// The slope deviation alpha = 255 encodes (the shader's kMapSigmaMax).
inline constexpr double kMapSigmaMax = 0.5;

// Every level of `map` (RGB or RGBA, 8 bit, rows in file order), from the map
// itself (alpha 0) down to 1 x 1, as RGBA images; level k is
// max(1, w >> k) x max(1, h >> k), the sizes OpenGL expects. Level k's texel
// averages the level-0 texels it covers (a 2 x 2 box per level).
std::vector<image::Image8> specularMipChain(const image::Image8& map);

// The per-axis slope variance a level's texel stores (decoded from alpha).
double mipSlopeVariance(const image::Image8& level, int x, int y) noexcept;

}  // namespace mucosa::reflectance
