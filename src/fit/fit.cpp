#include <mucosa/fit/fit.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <span>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>

namespace mucosa::fit {

namespace {

std::vector<std::size_t> holdoutFrames(std::size_t n, int k) {
    std::vector<std::size_t> out;
    if (k <= 0) return out;
    for (int i = 0; i < k; ++i)
        out.push_back((static_cast<std::size_t>(2 * i + 1) * n) / static_cast<std::size_t>(2 * k));
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

// Weighted median of (value, weight) pairs.
double weightedMedian(std::vector<std::array<double, 2>>& v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a[0] < b[0]; });
    double total = 0;
    for (const auto& x : v) total += x[1];
    double acc = 0;
    for (const auto& x : v) {
        acc += x[1];
        if (acc >= 0.5 * total) return x[0];
    }
    return v.back()[0];
}

// The albedo's level is the frames' own (their exposure, with the vignetting
// divided out, so brighter than any pixel towards the edge of the view) and
// may exceed 1, which the texture (linear, [0, 1]) cannot hold: a clipped
// channel shifts the colour. If the 99.9th percentile of the seen texels'
// channels is above 1, the texture is divided by it and rho multiplied by it
// (the product, all that is ever rendered, is unchanged; rho(1) becomes that
// factor instead of 1). A percentile, not the largest: a few texels of
// highlight residue must not move rho(1) off 1 for frames whose albedo fits.
void normaliseAlbedo(FitResult& r) {
    std::vector<float> v;
    for (std::size_t t = 0; t < r.coverage.size(); ++t)
        if (r.coverage.data()[t] > 0)
            for (int c = 0; c < 3; ++c) v.push_back(r.texture.data()[3 * t + static_cast<std::size_t>(c)]);
    if (v.empty()) return;
    const auto q = v.begin() + static_cast<std::ptrdiff_t>(std::min(v.size() - 1, v.size() * 999 / 1000));
    std::nth_element(v.begin(), q, v.end());
    const double k = *q;
    if (!(k > 1.0) || !std::isfinite(k)) return;
    for (float& x : std::span(r.texture.data(), r.texture.size())) x = static_cast<float>(x / k);
    for (double& c : r.brdf.c) c *= k;
    for (auto& b : r.rhoBins) b[1] *= k;
    r.albedoScale = k;
}

}  // namespace

AtlasShape atlasShape(const mesh::Mesh& m, std::array<float, 2> uvMin, std::array<float, 2> uvMax, int N) {
    // |dP/du| and |dP/dv| per triangle, from its edges in space and in UV.
    std::vector<std::array<double, 2>> su, sv;
    su.reserve(m.indices.size() / 3);
    sv.reserve(m.indices.size() / 3);
    for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
        const auto i0 = m.indices[t], i1 = m.indices[t + 1], i2 = m.indices[t + 2];
        double e1[3], e2[3];
        for (int k = 0; k < 3; ++k) {
            e1[k] = m.positions[i1][k] - m.positions[i0][k];
            e2[k] = m.positions[i2][k] - m.positions[i0][k];
        }
        const double du1 = m.uvs[i1][0] - m.uvs[i0][0], dv1 = m.uvs[i1][1] - m.uvs[i0][1];
        const double du2 = m.uvs[i2][0] - m.uvs[i0][0], dv2 = m.uvs[i2][1] - m.uvs[i0][1];
        const double det = du1 * dv2 - du2 * dv1;
        if (std::fabs(det) < 1e-12) continue;
        double pu2 = 0, pv2 = 0;
        for (int k = 0; k < 3; ++k) {
            const double pu = (e1[k] * dv2 - e2[k] * dv1) / det, pv = (e2[k] * du1 - e1[k] * du2) / det;
            pu2 += pu * pu;
            pv2 += pv * pv;
        }
        const double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
                     cz = e1[0] * e2[1] - e1[1] * e2[0];
        const double area = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
        if (!(area > 0)) continue;
        su.push_back({std::sqrt(pu2), area});
        sv.push_back({std::sqrt(pv2), area});
    }
    const double mmU = weightedMedian(su), mmV = weightedMedian(sv);
    const double du = uvMax[0] - uvMin[0], dv = uvMax[1] - uvMin[1];
    AtlasShape a{N, N, 0.0};
    if (mmU > 0 && mmV > 0) {
        // Width : height = the rectangle's extent on the surface along u : along v,
        // rounded to a power of two; the texel count stays about N^2.
        const int e = static_cast<int>(std::lround(std::log2((du * mmU) / (dv * mmV))));
        const int wide = (std::abs(e) + 1) / 2, narrow = std::abs(e) / 2;
        const int longSide = std::min(16384, N << wide), shortSide = std::max(8, N >> narrow);
        a.width = e >= 0 ? longSide : shortSide;
        a.height = e >= 0 ? shortSide : longSide;
        a.texelMm = std::sqrt((du * mmU / a.width) * (dv * mmV / a.height));
    }
    return a;
}

FitResult fitFrames(const mesh::Mesh& mesh, const frames::FrameSet& set, const FitOptions& o) {
    const auto t0 = std::chrono::steady_clock::now();
    // Each frame's own exposure, unrecorded, would be read as shading (auto-
    // exposure brightens the far, dark views: delta comes out flattened);
    // recorded, it is divided out (loadFrameImage).
    if (set.autoExposure)
        for (std::size_t i = 0; i < set.frames.size(); ++i)
            if (!(set.frames[i].exposure > 0))
                throw InputError(
                    fmt::format("field 'frames[{}].exposure'", i), "",
                    "is missing and 'auto_exposure' is true: each frame was exposed at a gain of its own, which the "
                    "fit would take for shading; a dataset of mucosa render records it (its frames' .frame.json; "
                    "`mucosa dataset verify` copies them in), or render with a fixed exposure (--set "
                    "camera.auto_exposure=0)");
    if (!mesh.hasUvs())
        throw InputError("mesh", "",
                         "has no texture coordinates: prepare it with `mucosa mesh IN -o OUT --uv centerline`");
    if (!mesh.hasNormals()) throw InputError("mesh", "", "has no normals");
    if (o.textureSize < 8 || o.textureSize > 16384)
        throw InputError("texture size", "", fmt::format("must be in 8..16384, got {}", o.textureSize));
    if (o.holdout < 0 || static_cast<std::size_t>(o.holdout) >= set.frames.size())
        throw InputError(
            "holdout", "",
            fmt::format("must leave at least one frame to fit: {} of {} frames", o.holdout, set.frames.size()));
    // Memory: samples (one per pixel at most) and the atlas.
    std::uint64_t pixels = 0;
    for (const frames::Frame& f : set.frames) pixels += static_cast<std::uint64_t>(f.K.width) * f.K.height;
    requireMemory(
        saturatingMul(pixels, sizeof(Sample) + 24) +
            saturatingMul(static_cast<std::uint64_t>(o.textureSize) * o.textureSize, 128),  // up to 2 N^2 texels
        "the fit");

    const auto held = holdoutFrames(set.frames.size(), o.holdout);
    // Progress: one fraction rising from 0 to 1 over the stages, each its own
    // share: back-projection [0, 0.5), the joint solve [0.5, 0.8), the texture
    // [0.8, 0.9), the held-out frames [0.9, 1).
    constexpr double kSolveAt = 0.5, kTextureAt = 0.8, kHoldoutAt = 0.9;
    FitResult r;
    r.perFrame.resize(set.frames.size());
    std::vector<Sample> samples;
    for (std::size_t i = 0; i < set.frames.size(); ++i) {
        const frames::Frame& f = set.frames[i];
        if (o.progress)
            o.progress(fmt::format("back-projecting frame {}/{}", i + 1, set.frames.size()),
                       kSolveAt * static_cast<double>(i) / static_cast<double>(set.frames.size()));
        const bool isHeld = std::find(held.begin(), held.end(), i) != held.end();
        image::Image8 sat;
        const image::ImageF img = loadFrameImage(f, set.response, &sat, o.saturation);
        BackprojectStats st;
        std::vector<Sample> s = backproject(mesh, f, img, &sat, o, static_cast<std::uint32_t>(i), &st);
        r.perFrame[i] = st;
        if (st.hits == 0)
            throw InputError("frame", f.image.string(), "never sees the mesh (check camera_to_world and the units)");
        if (st.backFacing > st.hits / 2)
            throw InputError("frame", f.image.string(),
                             fmt::format("sees the back of the surface at {:.0f} % of its pixels: the camera is "
                                         "outside-in or the surface faces away from the lumen (turn it with `mucosa "
                                         "mesh IN -o OUT --orient lumen`)",
                                         100.0 * static_cast<double>(st.backFacing) / static_cast<double>(st.hits)));
        if (!isHeld) samples.insert(samples.end(), s.begin(), s.end());
    }
    // The atlas spans the UV rectangle of the mesh (texture coordinates outside
    // [0, 1], as centerline UVs along a long airway, are not wrapped).
    float umin = mesh.uvs[0][0], umax = umin, vmin = mesh.uvs[0][1], vmax = vmin;
    for (const auto& uv : mesh.uvs) {
        umin = std::min(umin, uv[0]);
        umax = std::max(umax, uv[0]);
        vmin = std::min(vmin, uv[1]);
        vmax = std::max(vmax, uv[1]);
    }
    if (umin >= 0 && vmin >= 0 && umax <= 1 && vmax <= 1) {
        r.uvMin = {0, 0};
        r.uvMax = {1, 1};
    } else {
        r.uvMin = {umin, vmin};
        r.uvMax = {umax, vmax};
    }
    const AtlasShape shape = atlasShape(mesh, r.uvMin, r.uvMax, o.textureSize);
    r.atlasSize = {shape.width, shape.height};
    r.texelMm = shape.texelMm;
    if (o.progress) o.progress("fitting rho(gamma) and delta(r)", kSolveAt);
    r.brdf = solveBrdf(samples, o, &r);
    if (o.progress) o.progress("building the texture", kTextureAt);
    buildTexture(samples, r.brdf, o, r);
    normaliseAlbedo(r);

    for (std::size_t k = 0; k < held.size(); ++k) {
        const std::size_t i = held[k];
        const frames::Frame& f = set.frames[i];
        if (o.progress)
            o.progress(fmt::format("validating on held-out frame {} ({}/{})", i, k + 1, held.size()),
                       kHoldoutAt + (1.0 - kHoldoutAt) * static_cast<double>(k) / static_cast<double>(held.size()));
        image::Image8 sat;
        const image::ImageF real = loadFrameImage(f, set.response, &sat, o.saturation);
        std::vector<std::uint8_t> seen;
        const image::ImageF pred = renderPrediction(mesh, f, r.brdf, r.texture, r.uvMin, r.uvMax, &seen, o.threads);
        HoldoutResult h;
        h.frame = i;
        h.image = f.image.filename().string();
        double se = 0;
        for (int y = 0; y < f.K.height; ++y)
            for (int x = 0; x < f.K.width; ++x) {
                const std::size_t pi = static_cast<std::size_t>(y) * f.K.width + x;
                if (!seen[pi]) continue;
                double e2 = 0, lumReal = 0, lumPred = 0;
                for (int c = 0; c < 3; ++c) {
                    const double e = real.at(x, y, c) - pred.at(x, y, c);
                    e2 += e * e;
                    lumReal += real.at(x, y, c);
                    lumPred += pred.at(x, y, c);
                }
                // Highlights (and saturation) are masked: the model has no specular term.
                if (sat.at(x, y) || lumReal > 1.25 * lumPred + 0.09) {
                    ++h.masked;
                    continue;
                }
                se += e2;
                h.compared += 3;
            }
        h.psnr = h.compared ? 10.0 * std::log10(1.0 / std::max(1e-12, se / static_cast<double>(h.compared))) : 0.0;
        h.compared /= 3;
        r.holdout.push_back(h);
    }
    if (set.response.flare > 0)
        r.warnings.push_back(fmt::format(
            "the frames carry veiling glare (flare {:g}: that share of each view's mean radiance on every pixel), "
            "which the fit does not undo: it lifts the dark, distant samples and flattens the fitted fall-off; "
            "render with --set camera.flare=0 for a fit",
            set.response.flare));
    r.totalSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (o.progress) o.progress("fitted", 1.0);
    return r;
}

}  // namespace mucosa::fit
