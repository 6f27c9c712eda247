#pragma once
// Surface attributes at a rasterised pixel (perspective-correct barycentrics).
#include <cmath>

#include <mucosa/frames/frames.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/raster/raster.hpp>

namespace mucosa::fit::detail {

struct SurfacePoint {
    frames::Vec3d P, N;
    double u, v;
};

inline SurfacePoint surfaceAt(const mesh::Mesh& m, std::int32_t tri, double b1, double b2) {
    const double b0 = 1.0 - b1 - b2;
    const std::uint32_t i0 = m.indices[3 * static_cast<std::size_t>(tri)];
    const std::uint32_t i1 = m.indices[3 * static_cast<std::size_t>(tri) + 1];
    const std::uint32_t i2 = m.indices[3 * static_cast<std::size_t>(tri) + 2];
    SurfacePoint s{};
    for (int k = 0; k < 3; ++k) {
        s.P[k] = b0 * m.positions[i0][k] + b1 * m.positions[i1][k] + b2 * m.positions[i2][k];
        s.N[k] = b0 * m.normals[i0][k] + b1 * m.normals[i1][k] + b2 * m.normals[i2][k];
    }
    const double len = std::sqrt(s.N[0] * s.N[0] + s.N[1] * s.N[1] + s.N[2] * s.N[2]);
    for (double& c : s.N) c = len > 0 ? c / len : 0.0;
    s.u = b0 * m.uvs[i0][0] + b1 * m.uvs[i1][0] + b2 * m.uvs[i2][0];
    s.v = b0 * m.uvs[i0][1] + b1 * m.uvs[i1][1] + b2 * m.uvs[i2][1];
    return s;
}

// gamma = cos(V, N) with V from the point to the viewpoint; z = |viewpoint - P|.
inline void viewTerms(const SurfacePoint& s, const frames::Vec3d& eye, double& gamma, double& z) {
    const frames::Vec3d V{eye[0] - s.P[0], eye[1] - s.P[1], eye[2] - s.P[2]};
    z = std::sqrt(V[0] * V[0] + V[1] * V[1] + V[2] * V[2]);
    gamma = z > 0 ? (V[0] * s.N[0] + V[1] * s.N[1] + V[2] * s.N[2]) / z : 0.0;
}

// The gbuffer pixel an image pixel looks through (undistorted pinhole grid).
inline bool gbufferPixel(const frames::Intrinsics& K, int px, int py, int& gx, int& gy) {
    if (K.k1 == 0 && K.k2 == 0) {
        gx = px;
        gy = py;
        return true;
    }
    const auto n = frames::unproject(K, px, py);
    gx = static_cast<int>(std::lround(K.fx * n[0] + K.cx));
    gy = static_cast<int>(std::lround(K.fy * n[1] + K.cy));
    return gx >= 0 && gy >= 0 && gx < K.width && gy < K.height;
}

}  // namespace mucosa::fit::detail
