#pragma once
// What the registration's phases share (private to src/register): each phase
// is one file, the image side's pq estimation (pq_image.cpp), the model side
// (model_view.cpp, albedo_map.cpp), the objective (objective.cpp), the
// optimiser (optimiser.cpp), the tracker and its searches (tracker.cpp,
// initial_search.cpp), and the pose arithmetic they all use (pose.cpp).
#include <chrono>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Dense>

#include <mucosa/fit/fit.hpp>
#include <mucosa/frames/frames.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/register/register.hpp>
#include <mucosa/shading/brdf.hpp>

namespace mucosa::registration::detail {

using Clock = std::chrono::steady_clock;
inline double secondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// ------------------------------------------------ the image side (pq_image.cpp)

// Thin dark vessels and small bright glints are albedo and specularity, not
// shape: a grey-scale opening then closing of radius r removes them and
// leaves shading that varies over a larger scale nearly as is. Both sides
// are filtered alike.
image::ImageF openClose(const image::ImageF& E, const std::vector<std::uint8_t>& use, int r);

// The estimator, both sides. `E`: linear irradiance; `use`: pixels that may
// be used; `darkLevel`: the video's dark lumen (its weight's brightness term);
// `grazing`: the model's side (no mask on the normal, weight 1).
PqField estimate(const image::ImageF& E, std::vector<std::uint8_t> use, const frames::Intrinsics& K, const PqOptions& o,
                 double darkLevel, bool grazing = false);

// The q-quantile (q in 0..1) of v: its element of rank floor(q (n - 1)); 0 for none.
double percentile(std::vector<float> v, double q);

// ------------------------------------------------------------- pose arithmetic

using Mat3 = Eigen::Matrix3d;

inline Mat3 rotationOf(const frames::Mat4& m) {
    Mat3 R;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R(r, c) = m[r][c];
    return R;
}

// --------------------------------------------- the model side (model_view.cpp)

// A frame's neighbourhood as a small mesh (positions, normals, indices).
// `kept` (optional): each of its vertices' index in `m`.
mesh::Mesh submesh(const mesh::Mesh& m, const std::vector<std::uint32_t>& tris,
                   std::vector<std::uint32_t>* kept = nullptr);

// The neighbourhood and the options to register in it: an albedo per vertex
// (AlbedoMap) follows its vertices into the small mesh.
struct Neighbourhood {
    mesh::Mesh mesh;
    RegisterOptions options;
};
Neighbourhood neighbourhood(const mesh::Mesh& m, const frames::Vec3d& centre, double radius, const RegisterOptions& o);

// The interpolated vertex normal of triangle t at barycentrics bs, in the
// camera's axes (R: world to camera), unit. (Plain arithmetic: these run per
// sample, and Eigen's 3-vectors were a fifth of a registration's time in the
// sanitized build, where they are not inlined.)
inline frames::Vec3d cameraNormal(const mesh::Mesh& mesh, std::int32_t t, const double (&bs)[3], const Mat3& R) {
    double nw[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) {
        const auto& nn = mesh.normals[mesh.indices[3 * static_cast<std::size_t>(t) + k]];
        for (int c = 0; c < 3; ++c) nw[c] += bs[k] * nn[c];
    }
    const double* r = R.data();  // column-major
    const double n[3] = {r[0] * nw[0] + r[3] * nw[1] + r[6] * nw[2], r[1] * nw[0] + r[4] * nw[1] + r[7] * nw[2],
                         r[2] * nw[0] + r[5] * nw[1] + r[8] * nw[2]};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    return {n[0] / len, n[1] / len, n[2] / len};
}

inline double dot3(const frames::Vec3d& a, const Eigen::Vector3d& b) {
    const double* v = b.data();
    return a[0] * v[0] + a[1] * v[1] + a[2] * v[2];
}

// What the model shows at one rasterised sample: the lamp (or the fitted
// rho delta) on the surface point P (camera space) of triangle t at
// barycentrics bs, times `albedo`. `lit`: the point is lit (not back-facing).
inline double shadeSample(const mesh::Mesh& mesh, std::int32_t t, const double (&bs)[3], const Eigen::Vector3d& P,
                          const Mat3& R, const frames::Vec3d& L, const frames::LampProfile& lamp,
                          const shading::BrdfParams* brdf, double albedo, bool& lit) {
    const frames::Vec3d nc = cameraNormal(mesh, t, bs, R);
    const double* p = P.data();
    lit = false;
    if (brdf) {
        // The fitted model: lit from the viewpoint.
        const double z = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), gamma = -dot3(nc, P) / z;
        if (gamma <= 0) return 0.0;
        lit = true;
        return albedo * fit::fittedShading(*brdf, gamma, z);
    }
    // The walls' back-scatter: the renderer's ambient, k_a x the lamp at 10 mm.
    double sum = albedo * lamp.ambient / 100.0;
    const double l[3] = {L[0] - p[0], L[1] - p[1], L[2] - p[2]};
    const double d = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    const double cosine = (nc[0] * l[0] + nc[1] * l[1] + nc[2] * l[2]) / d;
    // The lamp's profile: theta from its axis (the optical axis).
    const double profile = lamp.spread == 0 ? 1.0 : std::exp(-lamp.spread * (1.0 + l[2] / d));
    if (cosine > 0) {
        sum += albedo * cosine * profile / (d * d + lamp.radiusMm * lamp.radiusMm);
        lit = true;
    }
    return sum;
}

// ------------------------------------------------- the objective (objective.cpp)

// A pose's cost on one level of a frame, for the optimiser and the initial
// search: the residual's pixels are fixed when it is made.
struct Objective {
    double cauchy2 = 0.25;  // squared scale of the Cauchy loss
    const mesh::Mesh& mesh;
    const VideoFrame::Level& level;
    const RegisterOptions& o;
    std::vector<std::size_t> pixels;  // the residual's pixels (fixed for the level)
    double videoMean = 0, videoStd = 1;
    FrameRegistration* stats;  // timing and render counts go here

    Objective(const mesh::Mesh& m, const VideoFrame::Level& l, const RegisterOptions& opt, FrameRegistration& st);

    // Per-pixel difference vectors at a pose (3 per pixel for pq, 1 for
    // intensity) and the similarity there.
    // `seen` (optional): 1 where the model has an estimate at the pixel.
    std::vector<double> differences(const frames::Mat4& pose, double* similarity,
                                    std::vector<std::uint8_t>* seen = nullptr);

    int block() const { return o.method == RegistrationMethod::PqSpace ? 3 : 1; }
    double weight(std::size_t k) const {
        return o.method == RegistrationMethod::PqSpace ? level.pq.weight[pixels[k]] : 1.0;
    }
};

// Cauchy loss on the per-pixel difference norm (pq: |n_video - n_model|^2 =
// 2 - 2 cos): a pixel whose model normal is far off (a specular streak, a
// vessel edge) stops pulling once it is clearly an outlier.
double robustCost(const Objective& obj, const std::vector<double>& d);

// ----------------------------------------------------- the tracker (tracker.cpp)

// Which of two registrations of a frame to keep: a converged one over a
// flagged one, then the higher similarity.
bool outranks(const FrameRegistration& a, const FrameRegistration& b) noexcept;

}  // namespace mucosa::registration::detail
