// The albedo atlas: every sample divided by the fitted shading is an estimate
// of its texel's albedo; estimates are blended with weight gamma * (1 - r/2)
// (frontal and near views are sharper and less noisy), highlights rejected
// against a first robust estimate, and texels no frame saw are filled by
// push-pull inpainting.
#include <algorithm>
#include <cmath>

#include <mucosa/fit/fit.hpp>

namespace mucosa::fit {

namespace {

struct Atlas {
    int size;
    std::array<float, 2> uvMin, uvMax;
    // Texel of (u, v); the first row of the atlas is the top (v = uvMax).
    int index(float u, float v) const {
        const int x = std::clamp(static_cast<int>((u - uvMin[0]) / (uvMax[0] - uvMin[0]) * size), 0, size - 1);
        const int y = std::clamp(static_cast<int>((1.0f - (v - uvMin[1]) / (uvMax[1] - uvMin[1])) * size), 0, size - 1);
        return y * size + x;
    }
};

}  // namespace

void pushPull(image::ImageF& color, const image::ImageF& weight) {
    // Pull: a pyramid of premultiplied colour and weight, halving each level.
    struct Level {
        int w, h;
        std::vector<float> c, wt;  // c premultiplied by wt, 3 channels
    };
    std::vector<Level> levels;
    Level base{color.width(), color.height(), {}, {}};
    base.c.resize(color.size());
    base.wt.resize(weight.size());
    for (std::size_t i = 0; i < weight.size(); ++i) {
        const float w = std::min(1.0f, weight.data()[i]);  // a seen texel is trusted fully
        base.wt[i] = w;
        for (int k = 0; k < 3; ++k) base.c[3 * i + k] = color.data()[3 * i + k] * w;
    }
    levels.push_back(std::move(base));
    while (levels.back().w > 1 || levels.back().h > 1) {
        const Level& f = levels.back();
        Level c{std::max(1, (f.w + 1) / 2), std::max(1, (f.h + 1) / 2), {}, {}};
        c.c.assign(static_cast<std::size_t>(c.w) * c.h * 3, 0.f);
        c.wt.assign(static_cast<std::size_t>(c.w) * c.h, 0.f);
        for (int y = 0; y < f.h; ++y)
            for (int x = 0; x < f.w; ++x) {
                const std::size_t fi = static_cast<std::size_t>(y) * f.w + x;
                const std::size_t ci = static_cast<std::size_t>(y / 2) * c.w + x / 2;
                c.wt[ci] += f.wt[fi];
                for (int k = 0; k < 3; ++k) c.c[3 * ci + k] += f.c[3 * fi + k];
            }
        // Clamp weights at 1 so that well-covered areas stay opaque (Gortler 1996).
        for (std::size_t i = 0; i < c.wt.size(); ++i)
            if (c.wt[i] > 1.0f) {
                for (int k = 0; k < 3; ++k) c.c[3 * i + k] /= c.wt[i];
                c.wt[i] = 1.0f;
            }
        levels.push_back(std::move(c));
    }
    // Push: from coarse to fine, fill the missing weight from the coarser level.
    for (int l = static_cast<int>(levels.size()) - 2; l >= 0; --l) {
        Level& f = levels[static_cast<std::size_t>(l)];
        const Level& c = levels[static_cast<std::size_t>(l) + 1];
        for (int y = 0; y < f.h; ++y)
            for (int x = 0; x < f.w; ++x) {
                const std::size_t fi = static_cast<std::size_t>(y) * f.w + x;
                const std::size_t ci = static_cast<std::size_t>(y / 2) * c.w + x / 2;
                const float missing = 1.0f - f.wt[fi];
                if (missing <= 0 || c.wt[ci] <= 0) continue;
                for (int k = 0; k < 3; ++k) f.c[3 * fi + k] += missing * c.c[3 * ci + k] / c.wt[ci];
                f.wt[fi] = 1.0f;
            }
    }
    const Level& f = levels[0];
    for (std::size_t i = 0; i < weight.size(); ++i)
        for (int k = 0; k < 3; ++k) color.data()[3 * i + k] = f.wt[i] > 0 ? f.c[3 * i + k] / f.wt[i] : 0.0f;
}

void buildTexture(const std::vector<Sample>& samples, const BrdfParams& brdf, const FitOptions& o, FitResult& r) {
    const int N = o.textureSize;
    const Atlas atlas{N, r.uvMin, r.uvMax};
    r.texture = image::ImageF(N, N, 3);
    r.coverage = image::ImageF(N, N, 1);
    std::vector<double> acc(static_cast<std::size_t>(N) * N * 3, 0.0), wsum(static_cast<std::size_t>(N) * N, 0.0);
    std::vector<float> invShade(samples.size());
    for (std::size_t i = 0; i < samples.size(); ++i) {
        const double shade = brdf.shading(samples[i].gamma, samples[i].z);
        invShade[i] = shade > 1e-4 ? static_cast<float>(1.0 / shade) : 0.0f;
    }
    auto estimate = [&](const Sample& s, int k) { return static_cast<double>(s.I[k] * invShade[&s - samples.data()]); };
    auto weightOf = [&](const Sample& s) { return s.gamma * (1.0 - 0.5 * std::clamp(brdf.r(s.z), 0.0, 1.0)); };
    // Pass 1: a robust first estimate per texel (weighted mean).
    for (const Sample& s : samples) {
        const int t = atlas.index(s.u, s.v);
        const double w = weightOf(s);
        wsum[t] += w;
        for (int k = 0; k < 3; ++k) acc[3 * t + k] += w * estimate(s, k);
    }
    std::vector<float> first(acc.size());
    for (std::size_t t = 0; t < wsum.size(); ++t)
        for (int k = 0; k < 3; ++k) first[3 * t + k] = wsum[t] > 0 ? static_cast<float>(acc[3 * t + k] / wsum[t]) : 0.f;
    // Pass 2: drop estimates far above the first (specular highlights) and blend.
    std::fill(acc.begin(), acc.end(), 0.0);
    std::fill(wsum.begin(), wsum.end(), 0.0);
    for (const Sample& s : samples) {
        const int t = atlas.index(s.u, s.v);
        double lum = 0, ref = 0;
        for (int k = 0; k < 3; ++k) {
            lum += estimate(s, k);
            ref += first[3 * t + k];
        }
        if (lum > 1.25 * ref + 0.03) continue;
        const double w = weightOf(s);
        wsum[t] += w;
        for (int k = 0; k < 3; ++k) acc[3 * t + k] += w * estimate(s, k);
    }
    std::size_t covered = 0;
    for (std::size_t t = 0; t < wsum.size(); ++t) {
        r.coverage.data()[t] = static_cast<float>(wsum[t]);
        if (wsum[t] > 0) ++covered;
        for (int k = 0; k < 3; ++k)
            r.texture.data()[3 * t + k] = wsum[t] > 0 ? static_cast<float>(acc[3 * t + k] / wsum[t]) : 0.f;
    }
    r.coveredFraction = static_cast<double>(covered) / static_cast<double>(wsum.size());
    pushPull(r.texture, r.coverage);
}

}  // namespace mucosa::fit
