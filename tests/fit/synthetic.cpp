#include "synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include <mucosa/image/png.hpp>
#include <mucosa/noise/perlin.hpp>
#include <mucosa/raster/raster.hpp>

namespace mucosa::test {

mesh::Mesh makeTube(double R, double L, int around, int along) {
    mesh::Mesh m;
    for (int j = 0; j <= along; ++j)
        for (int i = 0; i <= around; ++i) {
            const double a = 2 * M_PI * i / around, z = L * j / along;
            m.positions.push_back(
                {static_cast<float>(R * std::cos(a)), static_cast<float>(R * std::sin(a)), static_cast<float>(z)});
            m.normals.push_back({static_cast<float>(-std::cos(a)), static_cast<float>(-std::sin(a)), 0.f});
            m.uvs.push_back({static_cast<float>(static_cast<double>(i) / around),
                             static_cast<float>(static_cast<double>(j) / along)});
        }
    const auto idx = [&](int i, int j) { return static_cast<std::uint32_t>(j * (around + 1) + i); };
    for (int j = 0; j < along; ++j)
        for (int i = 0; i < around; ++i) {
            // Counter-clockwise seen from inside (where the normals face).
            m.indices.insert(m.indices.end(), {idx(i, j), idx(i, j + 1), idx(i + 1, j)});
            m.indices.insert(m.indices.end(), {idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1)});
        }
    return m;
}

std::array<double, 3> trueAlbedo(double u, double v) {
    const double base = 0.55 + 0.15 * std::sin(2 * M_PI * 3 * u) * std::cos(2 * M_PI * 2 * v) +
                        0.08 * noise::perlin(24 * u, 12 * v, 0.5);
    return {base * 0.95, base * 0.55, base * 0.5};
}

namespace {

frames::Vec3d cross(const frames::Vec3d& a, const frames::Vec3d& b) {
    return frames::Vec3d{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

frames::Vec3d norm(frames::Vec3d a) {
    const double l = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    return frames::Vec3d{a[0] / l, a[1] / l, a[2] / l};
}

frames::Mat4 cameraFrom(const frames::Vec3d& eye, frames::Vec3d fwd, const frames::Vec3d& up) {
    fwd = norm(fwd);
    const frames::Vec3d right = norm(cross(fwd, up));  // OpenCV: x right, y down, z forward
    const frames::Vec3d down = cross(fwd, right);
    frames::Mat4 m{};
    for (int r = 0; r < 3; ++r) m[r] = {right[r], down[r], fwd[r], eye[r]};
    m[3] = {0, 0, 0, 1};
    return m;
}

}  // namespace

frames::Mat4 lookAt(const frames::Vec3d& eye, const frames::Vec3d& target, const frames::Vec3d& up) {
    return cameraFrom(eye, {target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]}, up);
}

frames::FrameSet renderSynthetic(const mesh::Mesh& tube, const Truth& truth, const SyntheticOptions& o,
                                 const std::filesystem::path& dir) {
    std::vector<frames::Mat4> poses;
    for (int k = 0; k < o.frames; ++k) {
        // Off-axis eye, tilted view: gamma and distance decorrelate.
        const double ang = 2 * M_PI * k / o.frames;
        const double off = 2.5 + 3.5 * ((k * 7) % 5) / 4.0;
        const frames::Vec3d eye{off * std::cos(ang), off * std::sin(ang), 10.0 + 4.0 * (k % 4)};
        const double tilt = (20.0 + 8.0 * (k % 4)) * M_PI / 180.0;
        // Forward leans away from the axis toward the opposite wall.
        const frames::Vec3d fwd{-std::sin(tilt) * std::cos(ang + 0.6), -std::sin(tilt) * std::sin(ang + 0.6),
                                std::cos(tilt)};
        poses.push_back(cameraFrom(eye, fwd, {0, 1, 0}));
    }
    return renderSyntheticAt(tube, truth, poses, o, dir);
}

frames::FrameSet renderSyntheticAt(const mesh::Mesh& tube, const Truth& truth, const std::vector<frames::Mat4>& poses,
                                   const SyntheticOptions& o, const std::filesystem::path& dir) {
    frames::FrameSet set;
    std::mt19937 rng(o.seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double f = (o.size / 2.0) / std::tan(60.0 * M_PI / 180.0);  // 120 degree field of view
    for (std::size_t k = 0; k < poses.size(); ++k) {
        frames::Frame fr;
        fr.K = {o.size, o.size, f, f, o.size / 2.0, o.size / 2.0, 0, 0};
        fr.cameraToWorld = poses[k];
        const frames::Vec3d eye{fr.cameraToWorld[0][3], fr.cameraToWorld[1][3], fr.cameraToWorld[2][3]};
        fr.image = dir / ("frame_" + std::to_string(k) + ".png");

        const raster::GBuffer g = raster::rasterize(tube, fr.K, frames::invertRigid(fr.cameraToWorld));
        image::Image16 img(o.size, o.size, 3);
        for (int y = 0; y < o.size; ++y)
            for (int x = 0; x < o.size; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * o.size + x;
                std::array<double, 3> I{0.02, 0.02, 0.02};  // dark background where nothing is seen
                if (g.triangle[i] >= 0) {
                    const double b1 = g.b1[i], b2 = g.b2[i], b0 = 1 - b1 - b2;
                    const auto* id = &tube.indices[3 * static_cast<std::size_t>(g.triangle[i])];
                    frames::Vec3d P{}, N{};
                    double u = 0, v = 0;
                    for (int c = 0; c < 3; ++c) {
                        P[c] = b0 * tube.positions[id[0]][c] + b1 * tube.positions[id[1]][c] +
                               b2 * tube.positions[id[2]][c];
                        N[c] = b0 * tube.normals[id[0]][c] + b1 * tube.normals[id[1]][c] + b2 * tube.normals[id[2]][c];
                    }
                    N = norm(N);
                    u = b0 * tube.uvs[id[0]][0] + b1 * tube.uvs[id[1]][0] + b2 * tube.uvs[id[2]][0];
                    v = b0 * tube.uvs[id[0]][1] + b1 * tube.uvs[id[1]][1] + b2 * tube.uvs[id[2]][1];
                    frames::Vec3d V{eye[0] - P[0], eye[1] - P[1], eye[2] - P[2]};
                    const double z = std::sqrt(V[0] * V[0] + V[1] * V[1] + V[2] * V[2]);
                    V = norm(V);
                    const double gamma = N[0] * V[0] + N[1] * V[1] + N[2] * V[2];
                    const auto a = o.albedo ? o.albedo(u, v) : trueAlbedo(u, v);
                    // Glints: the normal perturbed by solid noise, a sharp Phong lobe.
                    const double e = 0.35;
                    frames::Vec3d Nb{N[0] + e * noise::perlin(P[0] * 1.3, P[1] * 1.3, P[2] * 1.3),
                                     N[1] + e * noise::perlin(P[1] * 1.3 + 17, P[2] * 1.3, P[0] * 1.3),
                                     N[2] + e * noise::perlin(P[2] * 1.3 + 31, P[0] * 1.3, P[1] * 1.3)};
                    Nb = norm(Nb);
                    const double ndv = std::max(0.0, Nb[0] * V[0] + Nb[1] * V[1] + Nb[2] * V[2]);
                    // A lamp's highlights fade with it; the cubic truth keeps them at full strength.
                    const double spec = o.specular * std::pow(ndv, 300.0) *
                                        (truth.lampRadius > 0 ? std::min(1.0, truth.delta(z)) : 1.0);
                    for (int c = 0; c < 3; ++c)
                        I[c] = a[c] * (truth.rho(std::max(0.0, gamma)) * truth.delta(z) + truth.flare) + spec;
                }
                for (int c = 0; c < 3; ++c) {
                    const double n = std::clamp(I[c] + o.noise * gauss(rng), 0.0, 1.0);
                    img.at(x, y, c) = static_cast<std::uint16_t>(std::lround(n * 65535.0));
                }
            }
        image::writePng(fr.image, img);
        set.frames.push_back(fr);
    }
    frames::writeFrames(dir / "frames.json", set);
    return set;
}

}  // namespace mucosa::test
