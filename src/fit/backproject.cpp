#include <mucosa/fit/fit.hpp>

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/image/png.hpp>

#include "surface.hpp"

namespace mucosa::fit {

std::vector<std::uint8_t> outsideFieldOfView(const image::ImageF& image, int marginPx) {
    const int W = image.width(), H = image.height(), C = image.channels();
    std::vector<std::uint8_t> outside(static_cast<std::size_t>(W) * H, 0);
    auto black = [&](std::size_t i) {
        for (int c = 0; c < C; ++c)
            if (image.data()[i * C + c] > 1e-6f) return false;
        return true;
    };
    std::vector<std::size_t> stack;
    auto seed = [&](int x, int y) {
        const std::size_t i = static_cast<std::size_t>(y) * W + x;
        if (!outside[i] && black(i)) outside[i] = 1, stack.push_back(i);
    };
    for (int x = 0; x < W; ++x) seed(x, 0), seed(x, H - 1);
    for (int y = 0; y < H; ++y) seed(0, y), seed(W - 1, y);
    while (!stack.empty()) {
        const std::size_t i = stack.back();
        stack.pop_back();
        const int x = static_cast<int>(i % W), y = static_cast<int>(i / W);
        if (x > 0) seed(x - 1, y);
        if (x + 1 < W) seed(x + 1, y);
        if (y > 0) seed(x, y - 1);
        if (y + 1 < H) seed(x, y + 1);
    }
    // Widen by marginPx (a square neighbourhood): rows, then columns.
    for (int pass = 0; pass < 2 && marginPx > 0; ++pass) {
        const std::vector<std::uint8_t> in = outside;
        const int n = pass == 0 ? W : H, lines = pass == 0 ? H : W;
        for (int l = 0; l < lines; ++l) {
            auto at = [&](int k) -> std::size_t {
                return pass == 0 ? static_cast<std::size_t>(l) * W + k : static_cast<std::size_t>(k) * W + l;
            };
            int last = -1 - marginPx;  // the nearest outside pixel at or before k
            for (int k = 0; k < n; ++k) {
                if (in[at(k)]) last = k;
                if (k - last <= marginPx) outside[at(k)] = 1;
            }
            last = n + marginPx;
            for (int k = n - 1; k >= 0; --k) {
                if (in[at(k)]) last = k;
                if (last - k <= marginPx) outside[at(k)] = 1;
            }
        }
    }
    return outside;
}

image::ImageF loadFrameImage(const frames::Frame& frame, const frames::Response& response, image::Image8* mask,
                             double saturation) {
    const image::PngImage png = image::readPng(frame.image);
    const image::Image16& px = png.pixels;
    if (px.width() != frame.K.width || px.height() != frame.K.height)
        throw InputError("image size", frame.image.string(),
                         fmt::format("is {}x{} but the frame's intrinsics say {}x{}", px.width(), px.height(),
                                     frame.K.width, frame.K.height));
    const double maxv = png.bitDepth == 16 ? 65535.0 : 255.0;
    image::ImageF out(px.width(), px.height(), 3);
    if (mask) *mask = image::Image8(px.width(), px.height(), 1);
    const int colour = px.channels() >= 3 ? 3 : 1;
    const bool enhanced = colour == 3 && response.colourGain != 1;
    for (int y = 0; y < px.height(); ++y)
        for (int x = 0; x < px.width(); ++x) {
            // The vignetting and the frame's recorded exposure (its gain) divided out.
            const double vignette = response.vignette(frame.K, x, y) * (frame.exposure > 0 ? frame.exposure : 1.0);
            bool sat = false;
            std::array<double, 3> v{};
            for (int c = 0; c < 3; ++c) {
                v[static_cast<std::size_t>(c)] = px.at(x, y, colour == 3 ? c : 0) / maxv;
                sat = sat || v[static_cast<std::size_t>(c)] >= saturation;
            }
            if (enhanced) {
                // The colour enhancement undone. A gain above 1 clips: a
                // channel at 0 beside lit ones may be one it clipped (one at 1
                // is caught above).
                const bool black = v[0] == 0 && v[1] == 0 && v[2] == 0;
                sat = sat || (response.colourGain > 1 && !black && (v[0] == 0 || v[1] == 0 || v[2] == 0));
                v = response.unenhance(v);
            }
            for (int c = 0; c < 3; ++c)
                out.at(x, y, c) = static_cast<float>(
                    response.linear(std::clamp(v[static_cast<std::size_t>(c)], 0.0, 1.0)) / vignette);
            if (mask) mask->at(x, y) = sat ? kMaskSaturated : 0;
        }
    if (mask) {
        const std::vector<std::uint8_t> outside = outsideFieldOfView(out, kViewMarginPx);
        for (std::size_t i = 0; i < outside.size(); ++i)
            if (outside[i]) mask->data()[i] = kMaskOutsideView;
    }
    return out;
}

std::vector<Sample> backproject(const mesh::Mesh& mesh, const frames::Frame& frame, const image::ImageF& linear,
                                const image::Image8* mask, const FitOptions& o, std::uint32_t frameIndex,
                                BackprojectStats* stats) {
    const frames::Mat4 W = frames::invertRigid(frame.cameraToWorld);
    const frames::Vec3d eye = frames::cameraCentre(frame.cameraToWorld);
    const raster::GBuffer g = raster::rasterize(mesh, frame.K, W, 0.05, o.threads);
    BackprojectStats st;
    std::vector<Sample> out;
    out.reserve(g.hits());
    for (int py = 0; py < frame.K.height; ++py)
        for (int px = 0; px < frame.K.width; ++px) {
            ++st.pixels;
            int gx, gy;
            if (!detail::gbufferPixel(frame.K, px, py, gx, gy)) continue;
            const std::size_t gi = static_cast<std::size_t>(gy) * g.width + gx;
            if (g.triangle[gi] < 0) continue;
            ++st.hits;
            const auto s = detail::surfaceAt(mesh, g.triangle[gi], g.b1[gi], g.b2[gi]);
            double gamma, z;
            detail::viewTerms(s, eye, gamma, z);
            if (gamma <= 0) {
                ++st.backFacing;
                continue;
            }
            if (gamma < o.minGamma) {
                ++st.grazing;
                continue;
            }
            Sample smp;
            for (int c = 0; c < 3; ++c) smp.I[c] = linear.at(px, py, c);
            if (mask && mask->at(px, py)) {
                ++(mask->at(px, py) == kMaskOutsideView ? st.outsideView : st.saturated);
                continue;
            }
            smp.u = static_cast<float>(s.u);
            smp.v = static_cast<float>(s.v);
            smp.gamma = static_cast<float>(gamma);
            smp.z = static_cast<float>(z);
            // The pixel's solid angle cos^3(theta) / (fx fy), theta off the
            // optical axis, seen at distance z and tilted by gamma.
            const double xn = (gx - frame.K.cx) / frame.K.fx, yn = (gy - frame.K.cy) / frame.K.fy;
            const double c2 = 1.0 / (1.0 + xn * xn + yn * yn);
            smp.footprint = static_cast<float>(z * z * c2 * std::sqrt(c2) / (frame.K.fx * frame.K.fy * gamma));
            smp.frame = frameIndex;
            out.push_back(smp);
        }
    st.samples = out.size();
    if (stats) *stats = st;
    return out;
}

image::ImageF renderPrediction(const mesh::Mesh& mesh, const frames::Frame& frame, const shading::BrdfParams& brdf,
                               const image::ImageF& tex, std::array<float, 2> uvMin, std::array<float, 2> uvMax,
                               std::vector<std::uint8_t>* seen, int threads) {
    const frames::Mat4 W = frames::invertRigid(frame.cameraToWorld);
    const frames::Vec3d eye = frames::cameraCentre(frame.cameraToWorld);
    const raster::GBuffer g = raster::rasterize(mesh, frame.K, W, 0.05, threads);
    image::ImageF out(frame.K.width, frame.K.height, 3);
    if (seen) seen->assign(static_cast<std::size_t>(frame.K.width) * frame.K.height, 0);
    const int tw = tex.width(), th = tex.height();
    for (int py = 0; py < frame.K.height; ++py)
        for (int px = 0; px < frame.K.width; ++px) {
            int gx, gy;
            if (!detail::gbufferPixel(frame.K, px, py, gx, gy)) continue;
            const std::size_t gi = static_cast<std::size_t>(gy) * g.width + gx;
            if (g.triangle[gi] < 0) continue;
            const auto s = detail::surfaceAt(mesh, g.triangle[gi], g.b1[gi], g.b2[gi]);
            double gamma, z;
            detail::viewTerms(s, eye, gamma, z);
            if (gamma <= 0) continue;
            // Bilinear texture lookup; first row of the atlas is the top (v max).
            const double fu = (s.u - uvMin[0]) / (uvMax[0] - uvMin[0]) * tw - 0.5;
            const double fv = (1.0 - (s.v - uvMin[1]) / (uvMax[1] - uvMin[1])) * th - 0.5;
            const int x0 = std::clamp(static_cast<int>(std::floor(fu)), 0, tw - 1);
            const int y0 = std::clamp(static_cast<int>(std::floor(fv)), 0, th - 1);
            const int x1 = std::min(x0 + 1, tw - 1), y1 = std::min(y0 + 1, th - 1);
            const double ax = std::clamp(fu - x0, 0.0, 1.0), ay = std::clamp(fv - y0, 0.0, 1.0);
            const double shade = fittedShading(brdf, gamma, z);
            for (int c = 0; c < 3; ++c) {
                const double a = (1 - ay) * ((1 - ax) * tex.at(x0, y0, c) + ax * tex.at(x1, y0, c)) +
                                 ay * ((1 - ax) * tex.at(x0, y1, c) + ax * tex.at(x1, y1, c));
                out.at(px, py, c) = static_cast<float>(a * shade);
            }
            if (seen) (*seen)[static_cast<std::size_t>(py) * frame.K.width + px] = 1;
        }
    return out;
}

}  // namespace mucosa::fit
