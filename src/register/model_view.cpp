// The model side of registration: the mesh near a pose, rendered as the
// lamp lights it (or with the patient's fitted shading and albedo), and the
// pq estimator run on that rendering, so that like is compared with like.
#include <mucosa/register/register.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include <mucosa/core/error.hpp>
#include <mucosa/raster/raster.hpp>

#include "phases.hpp"

namespace mucosa::registration {

using detail::estimate;
using detail::Mat3;
using detail::openClose;
using detail::rotationOf;
using detail::shadeSample;

namespace {

// The albedo at a rasterised sample: the per-vertex map, the atlas through
// the mesh's UVs, or 1.
double albedoAt(const mesh::Mesh& mesh, const ModelTexture* texture, std::int32_t t, const double (&bs)[3]) {
    if (!texture) return 1.0;
    const std::size_t base = 3 * static_cast<std::size_t>(t);
    if (!texture->perVertex.empty()) {
        double a = 0;
        for (int k = 0; k < 3; ++k) a += bs[k] * texture->perVertex[mesh.indices[base + k]];
        return a;
    }
    if (!mesh.hasUvs()) return 1.0;
    double u = 0, v = 0;
    for (int k = 0; k < 3; ++k) {
        const auto& uv = mesh.uvs[mesh.indices[base + k]];
        u += bs[k] * uv[0], v += bs[k] * uv[1];
    }
    return texture->at(u, v);
}

frames::Intrinsics scaled(const frames::Intrinsics& K, int ss) {
    frames::Intrinsics Ks = K;
    Ks.width = K.width * ss;
    Ks.height = K.height * ss;
    Ks.fx = K.fx * ss;
    Ks.fy = K.fy * ss;
    Ks.cx = (K.cx + 0.5) * ss - 0.5;
    Ks.cy = (K.cy + 0.5) * ss - 0.5;
    return Ks;
}

}  // namespace

namespace detail {

mesh::Mesh submesh(const mesh::Mesh& m, const std::vector<std::uint32_t>& tris, std::vector<std::uint32_t>* kept) {
    mesh::Mesh s;
    if (kept) kept->clear();
    std::vector<std::int64_t> remap(m.vertexCount(), -1);
    s.indices.reserve(tris.size() * 3);
    for (std::uint32_t t : tris)
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = m.indices[3 * static_cast<std::size_t>(t) + k];
            if (remap[v] < 0) {
                remap[v] = static_cast<std::int64_t>(s.positions.size());
                s.positions.push_back(m.positions[v]);
                s.normals.push_back(m.normals[v]);
                if (m.hasUvs()) s.uvs.push_back(m.uvs[v]);  // for a model texture
                if (kept) kept->push_back(v);
            }
            s.indices.push_back(static_cast<std::uint32_t>(remap[v]));
        }
    return s;
}

Neighbourhood neighbourhood(const mesh::Mesh& m, const frames::Vec3d& centre, double radius, const RegisterOptions& o) {
    Neighbourhood n;
    n.options = o;
    const bool perVertex = o.texture && !o.texture->perVertex.empty();
    std::vector<std::uint32_t> kept;
    n.mesh = submesh(m, trianglesNear(m, centre, radius), perVertex ? &kept : nullptr);
    if (perVertex) {
        if (o.texture->perVertex.size() != m.vertexCount())
            throw InputError("model texture", "registration", "has an albedo for a different number of vertices");
        auto t = std::make_shared<ModelTexture>();
        t->perVertex.reserve(kept.size());
        for (std::uint32_t v : kept) t->perVertex.push_back(o.texture->perVertex[v]);
        n.options.texture = std::move(t);
    }
    return n;
}

}  // namespace detail

double ModelTexture::at(double u, double v) const noexcept {
    const int w = luminance.width(), h = luminance.height();
    if (w == 0 || h == 0) return 1.0;
    double fu = (u - uvMin[0]) / (uvMax[0] - uvMin[0]), fv = (v - uvMin[1]) / (uvMax[1] - uvMin[1]);
    if (wrap) fu -= std::floor(fu), fv -= std::floor(fv);
    const double x = fu * w - 0.5, y = (1.0 - fv) * h - 0.5;
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double ax = x - x0, ay = y - y0;
    auto texel = [&](int xi, int yi) {
        if (wrap) {
            xi = ((xi % w) + w) % w;
            yi = ((yi % h) + h) % h;
        } else {
            xi = std::clamp(xi, 0, w - 1);
            yi = std::clamp(yi, 0, h - 1);
        }
        return static_cast<double>(luminance.at(xi, yi));
    };
    return (1 - ay) * ((1 - ax) * texel(x0, y0) + ax * texel(x0 + 1, y0)) +
           ay * ((1 - ax) * texel(x0, y0 + 1) + ax * texel(x0 + 1, y0 + 1));
}

ModelTexture modelTexture(const image::ImageF& rgb, std::array<float, 2> uvMin, std::array<float, 2> uvMax) {
    ModelTexture t;
    t.uvMin = uvMin;
    t.uvMax = uvMax;
    t.luminance = image::ImageF(rgb.width(), rgb.height(), 1);
    const int c = rgb.channels();
    for (int y = 0; y < rgb.height(); ++y)
        for (int x = 0; x < rgb.width(); ++x)
            t.luminance.at(x, y) =
                c >= 3 ? 0.2126f * rgb.at(x, y, 0) + 0.7152f * rgb.at(x, y, 1) + 0.0722f * rgb.at(x, y, 2)
                       : rgb.at(x, y, 0);
    return t;
}

ModelView renderModel(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& cameraToWorld,
                      const frames::Vec3d& L, int threads, int supersample, const frames::LampProfile& lamp,
                      const shading::BrdfParams* brdf, const ModelTexture* texture) {
    if (texture && !texture->perVertex.empty() && texture->perVertex.size() != mesh.vertexCount())
        throw InputError("model texture", "registration", "has an albedo for a different number of vertices");
    // Rendered at `supersample` x the resolution and box-filtered, as the
    // video's pixels integrate the scene: without it the model is point-
    // sampled, and the comparison favours a pose that aliases alike.
    const int ss = std::max(1, supersample);
    const frames::Intrinsics Ks = scaled(K, ss);
    const frames::Mat4 W = frames::invertRigid(cameraToWorld);
    const raster::GBuffer g = raster::rasterize(mesh, Ks, W, 0.5, threads);
    ModelView v;
    v.shading = image::ImageF(K.width, K.height, 1);
    v.depth = image::ImageF(K.width, K.height, 1);
    v.seen.assign(static_cast<std::size_t>(K.width) * K.height, 0);
    const Mat3 R = rotationOf(W);
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            double sum = 0, depth = 0;
            int hits = 0, lit = 0;
            for (int sy = 0; sy < ss; ++sy)
                for (int sx = 0; sx < ss; ++sx) {
                    const int X = x * ss + sx, Y = y * ss + sy;
                    const std::size_t i = static_cast<std::size_t>(Y) * Ks.width + X;
                    const std::int32_t t = g.triangle[i];
                    if (t < 0) continue;
                    ++hits;
                    const double z = g.depth[i];
                    depth += z;
                    const Eigen::Vector3d P((X - Ks.cx) / Ks.fx * z, (Y - Ks.cy) / Ks.fy * z, z);
                    const double b1 = g.b1[i], b2 = g.b2[i];
                    const double bs[3] = {1 - b1 - b2, b1, b2};
                    bool isLit = false;
                    sum += shadeSample(mesh, t, bs, P, R, L, lamp, brdf, albedoAt(mesh, texture, t, bs), isLit);
                    lit += isLit;
                }
            const std::size_t o = static_cast<std::size_t>(y) * K.width + x;
            v.shading.data()[o] = static_cast<float>(sum / (ss * ss));
            v.depth.data()[o] = hits ? static_cast<float>(depth / hits) : std::numeric_limits<float>::infinity();
            // Seen: every sub-sample hits a lit surface (a pixel on an
            // occluding contour or the mesh's edge mixes two surfaces).
            v.seen[o] = lit == ss * ss ? 1 : 0;
        }
    return v;
}

PqField pqFromModel(const ModelView& view, const frames::Intrinsics& K, const PqOptions& o,
                    const std::vector<std::uint8_t>* usable) {
    const std::size_t n = static_cast<std::size_t>(K.width) * K.height;
    std::vector<std::uint8_t> use(n);
    for (std::size_t i = 0; i < n; ++i)
        use[i] = view.seen[i] && view.shading.data()[i] > 0 && (!usable || (*usable)[i]);
    const image::ImageF filtered = openClose(view.shading, use, o.albedoFilterPx);
    return estimate(filtered, std::move(use), K, o, 0, true);
}

std::vector<std::uint32_t> trianglesNear(const mesh::Mesh& m, const frames::Vec3d& c, double radius) {
    std::vector<std::uint32_t> out;
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        double best = std::numeric_limits<double>::infinity();
        for (int k = 0; k < 3; ++k) {
            const auto& p = m.positions[m.indices[3 * t + k]];
            const double dx = p[0] - c[0], dy = p[1] - c[1], dz = p[2] - c[2];
            best = std::min(best, dx * dx + dy * dy + dz * dz);
        }
        if (best <= radius * radius) out.push_back(static_cast<std::uint32_t>(t));
    }
    return out;
}

}  // namespace mucosa::registration
