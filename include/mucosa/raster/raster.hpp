#pragma once
// A CPU z-buffer rasteriser for visibility: which triangle, at which
// perspective-correct barycentrics, each pixel of a pinhole camera sees. It is
// the depth pass of back-projection (no texel may take colour from a surface
// hidden behind another) and renders synthetic ground-truth frames in tests.
#include <cstdint>
#include <vector>

#include <mucosa/frames/frames.hpp>
#include <mucosa/mesh/mesh.hpp>

namespace mucosa::raster {

struct GBuffer {
    int width = 0, height = 0;
    std::vector<std::int32_t> triangle;  // -1: nothing seen
    std::vector<float> b1, b2;           // barycentrics of vertices 1 and 2 (b0 = 1 - b1 - b2)
    std::vector<float> depth;            // camera-space z (along the optical axis)
    std::size_t hits() const noexcept;
};

// Rasterises `mesh` for a pinhole camera with K's fx, fy, cx, cy (pixel centres
// at integer coordinates, no distortion: distortion is applied when sampling
// images, see src/fit/backproject.cpp), clipping at z = near. Both faces are kept.
GBuffer rasterize(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& worldToCamera,
                  double near = 0.05, int threads = 0);

}  // namespace mucosa::raster
