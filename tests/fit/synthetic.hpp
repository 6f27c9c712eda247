#pragma once
// Synthetic ground truth for the fit: a tube with known albedo, rendered with
// known rho and delta from off-axis, tilted endoscope poses, plus specular
// glints and sensor noise.
#include <array>
#include <filesystem>
#include <functional>
#include <vector>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/shading/brdf.hpp>

namespace mucosa::test {

// Tube along +z, radius R, length L, normals pointing into the lumen, UVs
// u = angle / 2 pi, v = z / L (the seam duplicated).
mesh::Mesh makeTube(double R, double L, int around, int along);

// Known albedo at (u, v): smooth tinted pattern with detail.
std::array<double, 3> trueAlbedo(double u, double v);

struct Truth {
    std::array<double, 4> c{0.25, 0.9, -0.3, 0.15};  // rho(1) = 1
    std::array<double, 3> d{-0.9, 0.45, -0.08};      // delta over s = (z - Z0)/(Z1 - Z0)
    double Z0 = 2.0, Z1 = 45.0;
    // > 0: delta is a lamp's inverse-square fall-off instead of the cubic,
    // (Z0^2 + a^2) / (z^2 + a^2) with a = lampRadius (1 at Z0; what a
    // bronchoscope's light does, and what no cubic in r fits exactly).
    double lampRadius = 0.0;
    double flare = 0.0;  // light scattered in the lumen and the optics: + albedo x flare, at any distance
    double rho(double g) const { return c[0] + g * (c[1] + g * (c[2] + g * c[3])); }
    double delta(double z) const {
        if (lampRadius > 0) return (Z0 * Z0 + lampRadius * lampRadius) / (z * z + lampRadius * lampRadius);
        const double s = (z - Z0) / (Z1 - Z0);
        return 1.0 + s * (d[0] + s * (d[1] + s * d[2]));
    }
};

struct SyntheticOptions {
    int frames = 12;
    int size = 320;
    double specular = 0.7;  // glint strength (0: none)
    double noise = 0.004;   // sensor noise sigma
    unsigned seed = 7;
    // Albedo at (u, v); empty: trueAlbedo.
    std::function<std::array<double, 3>(double u, double v)> albedo;
};

// Renders the frames as 16-bit PNGs into `dir` and returns the frame set
// (also written as dir/frames.json).
frames::FrameSet renderSynthetic(const mesh::Mesh& tube, const Truth& truth, const SyntheticOptions& o,
                                 const std::filesystem::path& dir);

// The same rendering at given camera poses (OpenCV camera_to_world; the
// 120-degree camera of `o.size` pixels; o.frames is ignored) of any mesh with
// UVs, albedo trueAlbedo(u, v).
frames::FrameSet renderSyntheticAt(const mesh::Mesh& mesh, const Truth& truth, const std::vector<frames::Mat4>& poses,
                                   const SyntheticOptions& o, const std::filesystem::path& dir);

// camera_to_world of an eye looking at `target` (OpenCV axes: x right, y down,
// z forward), `up` roughly up in the image.
frames::Mat4 lookAt(const frames::Vec3d& eye, const frames::Vec3d& target, const frames::Vec3d& up);

}  // namespace mucosa::test
