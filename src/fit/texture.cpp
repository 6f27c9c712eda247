// The albedo atlas: every sample divided by the fitted shading is an estimate
// of its texel's albedo; estimates are blended with weight
//   w = (rho delta)^2 min(1, texel area / pixel footprint)
// (inverse variance: I / (rho delta) carries the sensor's noise divided by the
// shading; and a pixel that covers k texels is their blur, worth 1/k of a
// sharp view), estimates whose shading is too dark to divide by are dropped,
// highlights are rejected against a first robust estimate, and texels no
// frame saw are filled by push-pull inpainting.
#include <mucosa/fit/fit.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/parallel.hpp>

namespace mucosa::fit {

namespace {

struct Atlas {
    int width, height;
    std::array<float, 2> uvMin, uvMax;
    // Texel of (u, v); the first row of the atlas is the top (v = uvMax).
    int index(float u, float v) const {
        const int x = std::clamp(static_cast<int>((u - uvMin[0]) / (uvMax[0] - uvMin[0]) * static_cast<float>(width)),
                                 0, width - 1);
        const int y =
            std::clamp(static_cast<int>((1.0f - (v - uvMin[1]) / (uvMax[1] - uvMin[1])) * static_cast<float>(height)),
                       0, height - 1);
        return y * width + x;
    }
};

// Shading below this (rho delta; 1 at zmin, head on) is too dark to divide
// by: 8-bit quantisation alone (1/255) would be an albedo error of 0.2.
constexpr double kMinShade = 0.02;
// A texel's estimate has noise sigma / sqrt(sum of shade^2) for a sensor
// noise sigma; at sigma = 1/255 this much weight keeps it below 0.03 (one
// sharp view at shade 0.13, or seven at 0.05). Texels with less are left to
// push-pull: far, dark views alone made coloured speckle.
constexpr double kMinTexelWeight = 0.017;

// Rows in parallel; every texel's value depends only on its own inputs, so
// the result is the same for any thread count.
template <class F>
void forRows(int rows, F f) {
    tbb::parallel_for(tbb::blocked_range<int>(0, rows, 16), [&](const tbb::blocked_range<int>& r) {
        for (int y = r.begin(); y < r.end(); ++y) f(y);
    });
}

// Push-pull on the calling thread's task arena (rows in parallel).
void pushPullRows(image::ImageF& color, const image::ImageF& weight) {
    // Pull: a pyramid of premultiplied colour and weight, halving each level.
    // Level 0 is `color` itself (premultiplied in place), so the only new
    // memory is the coarser levels (a third of the atlas).
    struct Level {
        int w, h;
        std::vector<float> c, wt;  // c premultiplied by wt, 3 channels
    };
    const int w0 = color.width(), h0 = color.height();
    float* c0 = color.data();
    std::vector<float> wt0(weight.size());
    forRows(h0, [&](int y) {
        for (std::size_t i = static_cast<std::size_t>(y) * w0; i < static_cast<std::size_t>(y + 1) * w0; ++i) {
            const float w = std::min(1.0f, weight.data()[i]);  // a seen texel is trusted fully
            wt0[i] = w;
            for (int k = 0; k < 3; ++k) c0[3 * i + k] *= w;
        }
    });
    std::vector<Level> levels;
    int fw = w0, fh = h0;
    const float* fc = c0;
    const float* fwt = wt0.data();
    while (fw > 1 || fh > 1) {
        Level c{std::max(1, (fw + 1) / 2), std::max(1, (fh + 1) / 2), {}, {}};
        c.c.assign(static_cast<std::size_t>(c.w) * c.h * 3, 0.f);
        c.wt.assign(static_cast<std::size_t>(c.w) * c.h, 0.f);
        // One coarse row from its (up to) two fine rows; weights clamped at 1
        // so that well-covered areas stay opaque (Gortler 1996).
        forRows(c.h, [&](int cy) {
            for (int y = 2 * cy; y < std::min(2 * cy + 2, fh); ++y)
                for (int x = 0; x < fw; ++x) {
                    const std::size_t fi = static_cast<std::size_t>(y) * fw + x;
                    const std::size_t ci = static_cast<std::size_t>(cy) * c.w + x / 2;
                    c.wt[ci] += fwt[fi];
                    for (int k = 0; k < 3; ++k) c.c[3 * ci + k] += fc[3 * fi + k];
                }
            for (std::size_t i = static_cast<std::size_t>(cy) * c.w; i < static_cast<std::size_t>(cy + 1) * c.w; ++i)
                if (c.wt[i] > 1.0f) {
                    const float inv = 1.0f / c.wt[i];
                    for (int k = 0; k < 3; ++k) c.c[3 * i + k] *= inv;
                    c.wt[i] = 1.0f;
                }
        });
        levels.push_back(std::move(c));
        fw = levels.back().w;
        fh = levels.back().h;
        fc = levels.back().c.data();
        fwt = levels.back().wt.data();
    }
    // Push: from coarse to fine, fill the missing weight from the coarser
    // level; at level 0, divide out the weight as well.
    for (int l = static_cast<int>(levels.size()) - 1; l >= 0; --l) {
        const Level& c = levels[static_cast<std::size_t>(l)];
        const bool base = l == 0;
        const int w = base ? w0 : levels[static_cast<std::size_t>(l) - 1].w;
        const int h = base ? h0 : levels[static_cast<std::size_t>(l) - 1].h;
        float* col = base ? c0 : levels[static_cast<std::size_t>(l) - 1].c.data();
        float* wt = base ? wt0.data() : levels[static_cast<std::size_t>(l) - 1].wt.data();
        forRows(h, [&](int y) {
            for (int x = 0; x < w; ++x) {
                const std::size_t fi = static_cast<std::size_t>(y) * w + x;
                const std::size_t ci = static_cast<std::size_t>(y / 2) * c.w + x / 2;
                const float missing = 1.0f - wt[fi];
                if (missing > 0 && c.wt[ci] > 0) {
                    const float s = missing / c.wt[ci];
                    for (int k = 0; k < 3; ++k) col[3 * fi + k] += s * c.c[3 * ci + k];
                    wt[fi] = 1.0f;
                }
                if (base) {
                    const float inv = wt[fi] > 0 ? 1.0f / wt[fi] : 0.0f;
                    for (int k = 0; k < 3; ++k) col[3 * fi + k] *= inv;
                }
            }
        });
    }
}

}  // namespace

void pushPull(image::ImageF& color, const image::ImageF& weight, int threads) {
    tbb::task_arena arena(resolveThreads(threads));
    arena.execute([&] { pushPullRows(color, weight); });
}

namespace {

// Sample indices ordered by texel (stable: within a texel, by index), by an
// LSD radix sort on 8-bit digits of the texel number: linear in the samples.
std::vector<std::uint32_t> orderByTexel(const std::vector<std::uint32_t>& texel, std::uint32_t texels) {
    const std::size_t n = texel.size();
    std::vector<std::uint32_t> order(n), tmp(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(i);
    for (int shift = 0; shift < 32 && (texels - 1) >> shift; shift += 8) {
        std::size_t count[257] = {};
        for (std::uint32_t i : order) count[((texel[i] >> shift) & 0xFF) + 1]++;
        for (int d = 0; d < 256; ++d) count[d + 1] += count[d];
        for (std::uint32_t i : order) tmp[count[(texel[i] >> shift) & 0xFF]++] = i;
        order.swap(tmp);
    }
    return order;
}

}  // namespace

void buildTexture(const std::vector<Sample>& samples, const shading::BrdfParams& brdf, const FitOptions& o,
                  FitResult& r) {
    const int W = r.atlasSize[0] > 0 ? r.atlasSize[0] : o.textureSize;
    const int H = r.atlasSize[1] > 0 ? r.atlasSize[1] : o.textureSize;
    const Atlas atlas{W, H, r.uvMin, r.uvMax};
    r.texture = image::ImageF(W, H, 3);
    r.coverage = image::ImageF(W, H, 1);
    const double texelArea = r.texelMm * r.texelMm;
    // Texel of every sample and its albedo estimate I / shading, computed once.
    const std::size_t n = samples.size();
    std::vector<std::uint32_t> texel(n);
    std::vector<float> invShade(n), weight(n);
    for (std::size_t i = 0; i < n; ++i) {
        const Sample& s = samples[i];
        const double shade = fittedShading(brdf, s.gamma, s.z);
        texel[i] = static_cast<std::uint32_t>(atlas.index(s.u, s.v));
        if (!(shade >= kMinShade)) {
            invShade[i] = 0.0f;
            weight[i] = 0.0f;
            continue;
        }
        invShade[i] = static_cast<float>(1.0 / shade);
        const double sharp = texelArea > 0 && s.footprint > texelArea ? texelArea / s.footprint : 1.0;
        weight[i] = static_cast<float>(shade * shade * sharp);
    }
    // Samples grouped by texel, so that every texel is one short sweep over
    // its own samples (no scattered passes over the atlas) and texels are
    // independent: groups in parallel, same result for any thread count.
    const std::vector<std::uint32_t> order = orderByTexel(texel, static_cast<std::uint32_t>(W) * H);
    float* tex = r.texture.data();
    float* cov = r.coverage.data();
    const auto texelValue = [&](std::size_t a, std::size_t b) {
        const std::uint32_t t = texel[order[a]];
        // Pass 1: a first estimate (weighted mean) of the texel's luminance.
        float acc[3] = {0, 0, 0}, wsum = 0;
        for (std::size_t j = a; j < b; ++j) {
            const std::uint32_t i = order[j];
            wsum += weight[i];
            for (int k = 0; k < 3; ++k) acc[k] += weight[i] * samples[i].I[k] * invShade[i];
        }
        if (!(wsum > 0)) return std::size_t{0};
        const float firstLum = (acc[0] + acc[1] + acc[2]) / wsum;
        // Pass 2: drop estimates far above the first (specular highlights) and blend.
        acc[0] = acc[1] = acc[2] = wsum = 0;
        for (std::size_t j = a; j < b; ++j) {
            const std::uint32_t i = order[j];
            const float lum = (samples[i].I[0] + samples[i].I[1] + samples[i].I[2]) * invShade[i];
            if (weight[i] <= 0 || lum > 1.25f * firstLum + 0.03f) continue;
            wsum += weight[i];
            for (int k = 0; k < 3; ++k) acc[k] += weight[i] * samples[i].I[k] * invShade[i];
        }
        if (!(wsum >= kMinTexelWeight)) return std::size_t{0};
        const float inv = 1.0f / wsum;
        for (int k = 0; k < 3; ++k) tex[3 * static_cast<std::size_t>(t) + k] = acc[k] * inv;
        cov[t] = wsum;
        return std::size_t{1};
    };
    std::atomic<std::size_t> covered{0};
    tbb::task_arena arena(resolveThreads(o.threads));
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& rg) {
            // A block owns the groups that start inside it.
            std::size_t j = rg.begin();
            while (j > 0 && j < n && texel[order[j]] == texel[order[j - 1]]) ++j;
            std::size_t mine = 0;
            while (j < rg.end()) {
                std::size_t e = j + 1;
                while (e < n && texel[order[e]] == texel[order[j]]) ++e;
                mine += texelValue(j, e);
                j = e;
            }
            covered += mine;
        });
    });
    r.coveredFraction = static_cast<double>(covered.load()) / (static_cast<double>(W) * H);
    // Push-pull trusts every texel a usable sample saw (the blend weights are
    // relative: their scale says nothing about how much to trust a texel).
    image::ImageF seen(W, H, 1);
    for (std::size_t i = 0; i < seen.size(); ++i) seen.data()[i] = cov[i] > 0 ? 1.0f : 0.0f;
    pushPull(r.texture, seen, o.threads);
}

}  // namespace mucosa::fit
