#include <mucosa/render/antialias.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include <mucosa/core/error.hpp>

namespace mucosa::render {

shading::Mat4 jitteredProjection(const shading::Mat4& projection, float dx, float dy, int width, int height) {
    // clip.x += (2 dx / W) clip.w: add a multiple of the w row to the x row.
    shading::Mat4 m = projection;
    const float sx = 2.0f * dx / static_cast<float>(width), sy = 2.0f * dy / static_cast<float>(height);
    for (int col = 0; col < 4; ++col) {
        m[static_cast<std::size_t>(col * 4 + 0)] += sx * m[static_cast<std::size_t>(col * 4 + 3)];
        m[static_cast<std::size_t>(col * 4 + 1)] += sy * m[static_cast<std::size_t>(col * 4 + 3)];
    }
    return m;
}

namespace {

using Plane = std::vector<float>;

// Mean over RGB per pixel.
Plane grey(const image::Image8& img) {
    Plane p(static_cast<std::size_t>(img.width()) * img.height());
    for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x)
            p[static_cast<std::size_t>(y) * img.width() + x] =
                static_cast<float>(img.at(x, y, 0) + img.at(x, y, 1) + img.at(x, y, 2)) / 3.0f;
    return p;
}

Plane specular(const image::Image8& lit, const image::Image8& diffuse) {
    Plane a = grey(lit);
    const Plane b = grey(diffuse);
    for (std::size_t i = 0; i < a.size(); ++i) a[i] = std::max(0.0f, a[i] - b[i]);
    return a;
}

// supersample x supersample box filter down to width x height, RGB floats.
std::vector<float> downsample(const image::Image8& big, int factor) {
    const int w = big.width() / factor, h = big.height() / factor;
    std::vector<float> out(static_cast<std::size_t>(w) * h * 3, 0.0f);
    const float inv = 1.0f / static_cast<float>(factor * factor);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) {
                float s = 0;
                for (int dy = 0; dy < factor; ++dy)
                    for (int dx = 0; dx < factor; ++dx) s += big.at(x * factor + dx, y * factor + dy, c);
                out[(static_cast<std::size_t>(y) * w + x) * 3 + static_cast<std::size_t>(c)] = s * inv;
            }
    return out;
}

}  // namespace

AliasingReport measureSpecularAliasing(OffscreenSession& session, const shading::FrameSetup& frame,
                                       const AliasingOptions& o) {
    if (o.jitterFrames < 2) throw InputError("jitter frames", "", "need at least 2");
    if (o.supersample < 1 || o.supersample > 8) throw InputError("supersample", "", "must be 1..8");
    const int w = frame.width, h = frame.height;
    const std::size_t n = static_cast<std::size_t>(w) * h;
    AliasingReport r;
    std::array<std::vector<Plane>, 2> seq;
    std::array<Plane, 2> mean{Plane(n, 0.0f), Plane(n, 0.0f)};
    for (int t = 0; t < o.jitterFrames; ++t) {
        // R2 low-discrepancy offsets (Roberts 2018), centred on the pixel.
        const double a1 = 0.7548776662466927, a2 = 0.5698402909980532;
        const float dx = static_cast<float>(std::fmod(0.5 + a1 * t, 1.0) - 0.5);
        const float dy = static_cast<float>(std::fmod(0.5 + a2 * t, 1.0) - 0.5);
        shading::FrameSetup f = frame;
        f.projection = jitteredProjection(frame.projection, dx, dy, w, h);
        shading::FrameSetup d = f;
        d.mode = shading::Mode::Diffuse;
        const image::Image8 diffuse = session.renderFrame(d);
        for (int aa = 0; aa < 2; ++aa) {
            f.specularAA = aa == 1;
            seq[static_cast<std::size_t>(aa)].push_back(specular(session.renderFrame(f), diffuse));
            const Plane& s = seq[static_cast<std::size_t>(aa)].back();
            for (std::size_t i = 0; i < n; ++i)
                mean[static_cast<std::size_t>(aa)][i] += s[i] / static_cast<float>(o.jitterFrames);
        }
    }
    std::vector<char> mask(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
        mask[i] = mean[0][i] > static_cast<float>(o.specularThreshold) ||
                  mean[1][i] > static_cast<float>(o.specularThreshold);
        r.maskPixels += static_cast<std::size_t>(mask[i]);
    }
    if (r.maskPixels == 0) return r;
    for (int aa = 0; aa < 2; ++aa) {
        const auto& s = seq[static_cast<std::size_t>(aa)];
        double diff = 0, energy = 0;
        for (std::size_t t = 1; t < s.size(); ++t)
            for (std::size_t i = 0; i < n; ++i)
                if (mask[i]) diff += std::fabs(s[t][i] - s[t - 1][i]);
        for (std::size_t i = 0; i < n; ++i)
            if (mask[i]) energy += mean[static_cast<std::size_t>(aa)][i];
        r.flicker[static_cast<std::size_t>(aa)] = diff / (double(r.maskPixels) * double(s.size() - 1));
        r.specularMean[static_cast<std::size_t>(aa)] = energy / double(r.maskPixels);
    }
    // Supersampled reference, anti-aliasing off (the band-limited truth is the
    // pixel's average of unfiltered shading).
    shading::FrameSetup big = frame;
    big.width = w * o.supersample;
    big.height = h * o.supersample;
    big.projection = frame.projection;  // same field of view: the aspect ratio is unchanged
    big.specularAA = false;
    const std::vector<float> ref = downsample(session.renderFrame(big), o.supersample);
    for (int aa = 0; aa < 2; ++aa) {
        shading::FrameSetup f = frame;
        f.specularAA = aa == 1;
        const image::Image8 img = session.renderFrame(f);
        double sum = 0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * w + x;
                if (!mask[i]) continue;
                for (int c = 0; c < 3; ++c) {
                    const double d = img.at(x, y, c) - ref[i * 3 + static_cast<std::size_t>(c)];
                    sum += d * d;
                }
            }
        r.errorVsReference[static_cast<std::size_t>(aa)] = std::sqrt(sum / (3.0 * double(r.maskPixels)));
    }
    return r;
}

}  // namespace mucosa::render
