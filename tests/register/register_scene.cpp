#include "register_scene.hpp"

#include <cmath>
#include <random>

#include <mucosa/mesh/primitives.hpp>
#include <mucosa/mesh/repair.hpp>
#include <mucosa/raster/raster.hpp>
#include <mucosa/register/register.hpp>

namespace mucosa::test {

namespace {

constexpr float kLength = 70.0f;

mesh::Mesh bumpyTube(int around, int along) {
    const float radius = 7.0f, length = kLength;
    struct {
        mesh::Mesh mesh;
    } s;
    s.mesh = mesh::makeTube(radius, length, around, along);
    // Bumps: the radius varies along and around the tube (rings, a fold), so
    // that sliding along the axis or rolling about it changes the picture.
    for (int j = 0; j <= along; ++j) {
        mesh::Vec3 c{0, 0, 0};
        for (int i = 0; i < around; ++i)
            for (int k = 0; k < 3; ++k) c[k] += s.mesh.positions[j * (around + 1) + i][k] / static_cast<float>(around);
        const double z = static_cast<double>(length) * j / along;
        for (int i = 0; i <= around; ++i) {
            auto& p = s.mesh.positions[j * (around + 1) + i];
            const double a = 2 * M_PI * i / around;
            const double f = 1 + 0.10 * std::sin(2 * M_PI * z / 9.0) + 0.07 * std::cos(2 * a + z / 6.0) +
                             0.05 * std::sin(3 * a - z / 11.0);
            for (int k = 0; k < 3; ++k) p[k] = static_cast<float>(c[k] + (p[k] - c[k]) * f);
        }
    }
    s.mesh.tangents.clear();
    mesh::recomputeNormals(s.mesh, 1);
    return s.mesh;
}

}  // namespace

RegisterScene makeRegisterScene(int frames) {
    RegisterScene s;
    s.mesh = bumpyTube(96, 240);
    s.truth = bumpyTube(192, 480);
    const auto centre = mesh::tubeCenterline(kLength, 701);  // 0.1 mm apart
    // About 0.6 mm and 2 degrees per frame: a scope advanced at ~15 mm/s
    // with a hand's roll, at 25 frames per second.
    for (int f = 0; f < frames; ++f) {
        const int i = 150 + f * 6;
        const auto& p = centre[i];
        const auto& q = centre[i + 100];
        const double roll = 0.025 * f;
        const frames::Vec3d off{1.2 * std::cos(0.3 * f), 0.8 * std::sin(0.2 * f), 0.0};
        const frames::Vec3d pos{p[0] + off[0], p[1] + off[1], p[2] + off[2]};
        const frames::Vec3d at{q[0] + 1.5 * std::cos(0.1 * f), q[1] - 1.0, q[2]};
        s.poses.push_back(frames::lookAtPose(pos, at, {std::sin(roll), std::cos(roll), 0.0}));
    }
    return s;
}

double albedoFactor(const frames::Vec3d& pw, double contrast) {
    // Procedural albedo on the surface: a network of thin dark vessels over
    // gentle blotches, as on airway mucosa.
    const double vessel = std::exp(-std::pow(std::sin(pw[0] * 0.9 + 0.8 * std::sin(pw[2] * 0.35)) / 0.08, 2)) +
                          std::exp(-std::pow(std::sin(pw[2] * 0.7 + 0.6 * std::sin(pw[1] * 0.5)) / 0.08, 2));
    return 1 + contrast *
                   (0.3 * std::sin(pw[0] * 0.6 + pw[2] * 0.25) * std::sin(pw[1] * 0.5) - 1.2 * std::min(1.0, vessel));
}

image::ImageF renderVideoFrame(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& pose,
                               const VideoOptions& o, int threads, image::Image8* saturated) {
    const frames::Mat4 W = frames::invertRigid(pose);
    const raster::GBuffer g = raster::rasterize(mesh, K, W, 0.05, threads);
    image::ImageF out(K.width, K.height, 3);
    if (saturated) *saturated = image::Image8(K.width, K.height, 1);
    std::mt19937 rng(o.seed);
    std::normal_distribution<double> noise(0.0, 1.0);
    const double R = 0.5 * std::min(K.width, K.height);
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * K.width + x;
            const double n0 = noise(rng), n1 = noise(rng), n2 = noise(rng);
            if (o.mask && std::hypot(x - K.cx, y - K.cy) > 0.97 * R) continue;  // outside the scope's view: black
            double e = 0, spec = 0;
            std::array<double, 3> albedo{0.85, 0.45, 0.35};
            const std::int32_t t = g.triangle[i];
            if (t >= 0) {
                const double z = g.depth[i];
                const frames::Vec3d P{(x - K.cx) / K.fx * z, (y - K.cy) / K.fy * z, z};
                const double b1 = g.b1[i], b2 = g.b2[i], bs[3] = {1 - b1 - b2, b1, b2};
                frames::Vec3d nw{0, 0, 0}, pw{0, 0, 0};
                for (int k = 0; k < 3; ++k) {
                    const auto v = mesh.indices[3 * static_cast<std::size_t>(t) + k];
                    for (int c = 0; c < 3; ++c)
                        nw[c] += bs[k] * mesh.normals[v][c], pw[c] += bs[k] * mesh.positions[v][c];
                }
                frames::Vec3d n = frames::transformDirection(W, nw);
                const double nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                for (double& c : n) c /= nn;
                const frames::Vec3d l{o.lightOffset[0] - P[0], o.lightOffset[1] - P[1], o.lightOffset[2] - P[2]};
                const double d = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
                const double cosine = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / d;
                if (cosine > 0) {
                    e = cosine / (d * d);
                    // Blinn-Phong glint, viewer at the origin.
                    const double pl = std::sqrt(P[0] * P[0] + P[1] * P[1] + P[2] * P[2]);
                    frames::Vec3d h{l[0] / d - P[0] / pl, l[1] / d - P[1] / pl, l[2] / d - P[2] / pl};
                    const double hn = std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
                    const double nh = (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]) / hn;
                    spec = o.specular * std::pow(std::max(0.0, nh), 60.0) / (d * d);
                }
                const double v = albedoFactor(pw, o.albedoContrast);
                for (double& a : albedo) a *= v;
            }
            bool sat = false;
            for (int c = 0; c < 3; ++c) {
                double val = 25.0 * o.gain * (albedo[c] * e + spec);
                val += o.noise * (c == 0 ? n0 : c == 1 ? n1 : n2) * (e > 0 || spec > 0 ? 1 : 0);
                val = std::clamp(val, 0.0, 1.0);
                sat = sat || val >= 0.999;
                out.at(x, y, c) = static_cast<float>(val);
            }
            if (saturated) saturated->at(x, y) = sat ? 1 : 0;
        }
    return out;
}

}  // namespace mucosa::test
