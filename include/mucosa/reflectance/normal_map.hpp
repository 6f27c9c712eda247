#pragma once
// Height field -> normals -> encoded reflectance map (the paper's eq. 1-2 and
// Fig. 1; DESIGN.md "Normals from the height field"):
//   Hu = B * dH/du, Hv = B * dH/dv   (central differences, u, v in map widths)
//   T = (1, 0, Hu), B = (0, 1, Hv), N = T x B / |T x B| = (-Hu, -Hv, 1) / |.|
//   rgb = 0.5 * N + 0.5
// Texture space is OpenGL's (and Blender's, and glTF's normal-texture
// convention, "green up"): +u runs left to right along a row, +v runs from the
// last row of the file (v = 0) up to the first (v = 1). So red = +u, green =
// toward the top of the image, blue = out of the surface.
#include <array>
#include <cstdint>

#include <mucosa/image/image.hpp>

namespace mucosa::reflectance {

enum class Edges {
    Wrap,   // tileable map: differences wrap around the edges
    Clamp,  // one-sided differences at the border
};

// Normal at (x, y) of the height field (1 channel), with bump strength B.
std::array<double, 3> normalAt(const image::ImageF& height, int x, int y, double strength, Edges edges) noexcept;

// Whole map, encoded; parallel over rows; same bytes for any thread count.
image::Image8 encodeNormals8(const image::ImageF& height, double strength, Edges edges, int threads = 0);
image::Image16 encodeNormals16(const image::ImageF& height, double strength, Edges edges, int threads = 0);

// One row of the encoded map (3 samples per texel), exactly as the whole-map
// functions write it; for streaming encoders.
void encodeNormalRow8(const image::ImageF& height, int y, double strength, Edges edges, std::uint8_t* row);
void encodeNormalRow16(const image::ImageF& height, int y, double strength, Edges edges, std::uint16_t* row);

// rgb = 0.5 N + 0.5, rounded to nearest.
std::array<std::uint8_t, 3> encode8(const std::array<double, 3>& N) noexcept;
std::array<std::uint16_t, 3> encode16(const std::array<double, 3>& N) noexcept;

// N = 2 rgb - 1, then renormalised (the decode a shader does).
std::array<double, 3> decode(const std::array<double, 3>& rgb01) noexcept;
std::array<double, 3> decode8(std::uint8_t r, std::uint8_t g, std::uint8_t b) noexcept;
std::array<double, 3> decode16(std::uint16_t r, std::uint16_t g, std::uint16_t b) noexcept;

}  // namespace mucosa::reflectance
