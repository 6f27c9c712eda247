// Pose arithmetic: a pose moved in its own camera axes (the optimiser's and
// the search's parameters) and the error between two poses.
#include <mucosa/register/register.hpp>

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "phases.hpp"

namespace mucosa::registration {

using detail::Mat3;
using detail::rotationOf;

namespace {

Mat3 rodrigues(const frames::Vec3d& w) {
    const Eigen::Vector3d v(w[0], w[1], w[2]);
    const double a = v.norm();
    if (a < 1e-12) return Mat3::Identity();
    return Eigen::AngleAxisd(a, v / a).toRotationMatrix();
}

}  // namespace

PoseError poseError(const frames::Mat4& a, const frames::Mat4& b) noexcept {
    PoseError e;
    const frames::Vec3d ca = frames::cameraCentre(a), cb = frames::cameraCentre(b);
    e.position = std::sqrt((ca[0] - cb[0]) * (ca[0] - cb[0]) + (ca[1] - cb[1]) * (ca[1] - cb[1]) +
                           (ca[2] - cb[2]) * (ca[2] - cb[2]));
    const Mat3 R = rotationOf(a).transpose() * rotationOf(b);
    e.degrees = std::acos(std::clamp((R.trace() - 1) / 2, -1.0, 1.0)) * 180 / M_PI;
    return e;
}

frames::Mat4 perturbPose(const frames::Mat4& m, const frames::Vec3d& t, const frames::Vec3d& w) noexcept {
    const Mat3 R = rotationOf(m);
    const Mat3 Rn = R * rodrigues(w);
    const Eigen::Vector3d tn = R * Eigen::Vector3d(t[0], t[1], t[2]) + Eigen::Vector3d(m[0][3], m[1][3], m[2][3]);
    frames::Mat4 o{};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) o[r][c] = Rn(r, c);
        o[r][3] = tn[r];
    }
    o[3] = {0, 0, 0, 1};
    return o;
}

}  // namespace mucosa::registration
