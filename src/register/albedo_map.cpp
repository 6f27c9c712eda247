// An albedo per vertex of the airway, learnt from the registered frames as
// the track goes (AlbedoMap; docs/theory.md, "An albedo learnt along the
// track"): part of the model side, whose renders it textures.
#include <mucosa/register/register.hpp>

#include <algorithm>
#include <cmath>
#include <memory>

#include <mucosa/core/error.hpp>
#include <mucosa/raster/raster.hpp>

#include "phases.hpp"

namespace mucosa::registration {

using detail::cameraNormal;
using detail::dot3;
using detail::Mat3;
using detail::percentile;
using detail::rotationOf;
using detail::shadeSample;
using detail::submesh;

std::size_t AlbedoMap::add(const mesh::Mesh& fullMesh, const VideoFrame& frame, const frames::Mat4& cameraToWorld,
                           const RegisterOptions& o) {
    if (fullMesh.vertexCount() != sum_.size())
        throw InputError("albedo map", "registration", "was made for a mesh with a different number of vertices");
    if (!fullMesh.hasNormals()) throw InputError("mesh", "albedo map", "has no normals");
    if (frame.levels.empty()) return 0;
    const VideoFrame::Level& level = frame.levels.back();
    const frames::Intrinsics& K = level.K;
    std::vector<std::uint32_t> kept;
    const mesh::Mesh mesh =
        submesh(fullMesh, trianglesNear(fullMesh, frames::cameraCentre(cameraToWorld), o.farMm), &kept);
    const frames::Mat4 W = frames::invertRigid(cameraToWorld);
    const raster::GBuffer g = raster::rasterize(mesh, K, W, 0.5, 1);
    const Mat3 R = rotationOf(W);
    const std::size_t n = static_cast<std::size_t>(K.width) * K.height;
    // The dark lumen carries noise, not albedo: the pq estimator's threshold.
    std::vector<float> inside;
    for (std::size_t i = 0; i < n; ++i)
        if (level.valid[i]) inside.push_back(level.luminance.data()[i]);
    const double dark = level.pqOptions.darkFraction * percentile(inside, 0.99);
    struct Observation {
        std::int32_t triangle;
        double b[3];
        double ratio, weight;
    };
    std::vector<Observation> obs;
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * K.width + x;
            const std::int32_t t = g.triangle[i];
            const double e = level.luminance.data()[i];
            if (t < 0 || !level.valid[i] || e <= dark) continue;
            const double z = g.depth[i];
            const Eigen::Vector3d P((x - K.cx) / K.fx * z, (y - K.cy) / K.fy * z, z);
            const double b1 = g.b1[i], b2 = g.b2[i];
            const double bs[3] = {1 - b1 - b2, b1, b2};
            bool lit = false;
            const double shade =
                shadeSample(mesh, t, bs, P, R, o.lightOffset, o.lamp, o.brdf ? &*o.brdf : nullptr, 1.0, lit);
            if (!lit || shade <= 0) continue;
            const double d = P.norm(), gamma = -dot3(cameraNormal(mesh, t, bs, R), P) / d;
            if (gamma <= 0.1) continue;  // grazing: the normal's error dominates the shading
            obs.push_back({t, {bs[0], bs[1], bs[2]}, e / shade, gamma * gamma / (d * d)});
        }
    if (obs.size() < 50) return 0;
    // The frame's exposure against what the map holds.
    std::vector<float> toMap, raw;
    for (const Observation& ob : obs) {
        raw.push_back(static_cast<float>(ob.ratio));
        double a = 0;
        bool known = true;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = kept[mesh.indices[3 * static_cast<std::size_t>(ob.triangle) + k]];
            if (weight_[v] <= 0)
                known = false;
            else
                a += ob.b[k] * sum_[v] / weight_[v];
        }
        if (known && a > 0) toMap.push_back(static_cast<float>(ob.ratio / a));
    }
    double gain = 0;
    if (toMap.size() >= 50)
        gain = percentile(toMap, 0.5);
    else {
        double seen = 0, mean = 0;
        for (std::size_t v = 0; v < sum_.size(); ++v)
            if (weight_[v] > 0) mean += sum_[v] / weight_[v], ++seen;
        gain = percentile(raw, 0.5) / (seen > 0 ? mean / seen : 1.0);
    }
    if (!(gain > 0)) return 0;
    std::size_t used = 0;
    for (const Observation& ob : obs) {
        const double a = ob.ratio / gain;
        if (a > 4 || a < 0.1) continue;  // a glint's fringe, a shadow the model lacks
        ++used;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = kept[mesh.indices[3 * static_cast<std::size_t>(ob.triangle) + k]];
            sum_[v] += ob.weight * ob.b[k] * a;
            weight_[v] += ob.weight * ob.b[k];
        }
    }
    ++frames_;
    return used;
}

std::shared_ptr<const ModelTexture> AlbedoMap::texture() const {
    auto t = std::make_shared<ModelTexture>();
    t->perVertex.resize(sum_.size());
    double mean = 0, seen = 0;
    for (std::size_t v = 0; v < sum_.size(); ++v)
        if (weight_[v] > 0) mean += sum_[v] / weight_[v], ++seen;
    mean = seen > 0 ? mean / seen : 1.0;
    for (std::size_t v = 0; v < sum_.size(); ++v)
        t->perVertex[v] = static_cast<float>(weight_[v] > 0 ? sum_[v] / weight_[v] : mean);
    return t;
}

double AlbedoMap::seenFraction() const noexcept {
    if (weight_.empty()) return 0;
    return static_cast<double>(std::count_if(weight_.begin(), weight_.end(), [](double w) { return w > 0; })) /
           static_cast<double>(weight_.size());
}

bool paintsAlbedoMap(const FrameRegistration& r, const RegisterOptions& o) noexcept {
    return r.converged && r.similarity >= o.minPaintSimilarity;
}

}  // namespace mucosa::registration
