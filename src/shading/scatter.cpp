#include <mucosa/shading/reference.hpp>
#include <mucosa/shading/scatter.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

#include <mucosa/core/error.hpp>

#include "glsl.hpp"

namespace mucosa::shading {

static_assert(kScatterTaps == glsl::kScatterTaps);

namespace {

constexpr double kPi = std::numbers::pi;
// The taps reach 10 d of the widest channel: the marginal's tail beyond it
// holds 1.0 % of its light.
constexpr double kReach = 10.0;

// The marginal's integral over [a, b] (0 <= a < b, in mm): midpoint rule in
// t with x = a + (b - a) t^2, which removes K0's logarithmic singularity at 0.
double marginalIntegral(double a, double b, double d) {
    constexpr int kSteps = 256;
    double sum = 0.0;
    for (int i = 0; i < kSteps; ++i) {
        const double t = (i + 0.5) / kSteps;
        const double x = a + (b - a) * t * t;
        sum += diffusionMarginal(x, d) * 2.0 * (b - a) * t;
    }
    return sum / kSteps;
}

}  // namespace

double diffusionProfile(double r, double d) {
    if (d <= 0.0 || r <= 0.0) return 0.0;
    return (std::exp(-r / d) + std::exp(-r / (3.0 * d))) / (8.0 * kPi * d * r);
}

double diffusionMarginal(double x, double d) {
    const double ax = std::abs(x);
    if (d <= 0.0 || ax <= 0.0) return 0.0;
    return (std::cyl_bessel_k(0.0, ax / d) + std::cyl_bessel_k(0.0, ax / (3.0 * d))) / (4.0 * kPi * d);
}

ScatterKernel scatterKernel(const std::array<float, 3>& distanceMm) {
    ScatterKernel k;
    const double widest = std::max({distanceMm[0], distanceMm[1], distanceMm[2], 0.0f});
    constexpr int side = glsl::kScatterSide;
    // Tap j (0 = the centre) at t_j = kReach widest (j / side)^2; its interval
    // reaches halfway to its neighbours (the last one's, to t_side).
    std::array<double, side + 1> t{};
    for (int j = 0; j <= side; ++j) t[j] = kReach * widest * (static_cast<double>(j) / side) * (double(j) / side);
    std::array<double, side + 2> edge{};  // edge[j]..edge[j + 1]: tap j's interval on the positive side
    edge[0] = 0.0;
    for (int j = 1; j <= side; ++j) edge[j] = 0.5 * (t[j - 1] + t[j]);
    edge[side + 1] = t[side];
    for (int c = 0; c < 3; ++c) {
        const double d = distanceMm[c];
        std::array<double, side + 1> w{};
        if (d <= 0.0 || widest <= 0.0) {
            w[0] = 1.0;
        } else {
            for (int j = 0; j <= side; ++j) w[j] = marginalIntegral(edge[j], edge[j + 1], d);
            w[0] *= 2.0;  // the centre's interval is symmetric: both halves
        }
        double total = w[0];
        for (int j = 1; j <= side; ++j) total += 2.0 * w[j];
        for (int j = 0; j <= side; ++j) {
            const float v = static_cast<float>(w[j] / total);
            k.weight[side + j][c] = v;
            k.weight[side - j][c] = v;
        }
    }
    for (int j = 0; j <= side; ++j) {
        k.offsetMm[side + j] = static_cast<float>(t[j]);
        k.offsetMm[side - j] = static_cast<float>(-t[j]);
    }
    return k;
}

bool scattersLight(const FrameSetup& frame) noexcept {
    const auto& d = frame.params.color(Param::Scatter);
    return glsl::modeScatters(static_cast<int>(frame.mode)) && std::max({d[0], d[1], d[2]}) > 0.0f &&
           frame.params[Param::ScatterShare] > 0.0f;
}

std::vector<float> applyScatter(const std::vector<float>& bodySpecular, const std::vector<float>& windowDepth, int w,
                                int h, const std::array<float, 16>& projection, const ScatterKernel& kernel,
                                float share) {
    const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    MUCOSA_CHECK(w > 0 && h > 0 && bodySpecular.size() == 4 * n && windowDepth.size() == n,
                 "applyScatter: the images do not hold w x h pixels");
    const float a = projection[10], b = projection[14];
    // The focal lengths in pixels along x and y: P[0][0] W / 2, P[1][1] H / 2.
    const float fx = projection[0] * 0.5f * static_cast<float>(w), fy = projection[5] * 0.5f * static_cast<float>(h);
    const glm::ivec4 rect(0, 0, w, h), half = glsl::scatterHalfRect(rect);
    const int hw = half.z, hh = half.w;
    auto depthAt = [&](int x, int y) {
        return glsl::scatterSurfaceDepth(windowDepth[static_cast<std::size_t>(y) * w + x], a, b);
    };
    auto body = [&](int x, int y) {
        const std::size_t i = 4 * (static_cast<std::size_t>(y) * w + x);
        return glm::vec3(bodySpecular[i], bodySpecular[i + 1], bodySpecular[i + 2]);
    };
    auto weight = [&](int k) { return glm::vec3(kernel.weight[k][0], kernel.weight[k][1], kernel.weight[k][2]); };
    // Pass 0: along x into the half-size image (rgb, eye depth).
    std::vector<glm::vec4> first(static_cast<std::size_t>(hw) * hh), second(first.size());
    for (int y = 0; y < hh; ++y)
        for (int x = 0; x < hw; ++x) {
            const int x0 = std::min(2 * x, w - 1), y0 = std::min(2 * y, h - 1);
            const glm::vec3 c = body(x0, y0);
            const float zc = depthAt(x0, y0);
            glm::vec3 sum = c;
            if (zc > 0.0f) {
                sum = glm::vec3(0.0f);
                for (int k = 0; k < kScatterTaps; ++k) {
                    const int qx = x0 + glsl::scatterOffsetPx(kernel.offsetMm[k], fx, zc);
                    glm::vec3 s = c;
                    if (qx >= 0 && qx < w && glsl::scatterAccepts(zc, depthAt(qx, y0), kernel.offsetMm[k]))
                        s = body(qx, y0);
                    sum += weight(k) * s;
                }
            }
            first[static_cast<std::size_t>(y) * hw + x] = glm::vec4(sum, zc);
        }
    // Pass 1: along y, half size.
    for (int y = 0; y < hh; ++y)
        for (int x = 0; x < hw; ++x) {
            const glm::vec4 c = first[static_cast<std::size_t>(y) * hw + x];
            glm::vec3 sum(c);
            if (c.w > 0.0f) {
                sum = glm::vec3(0.0f);
                for (int k = 0; k < kScatterTaps; ++k) {
                    const int qy = y + glsl::scatterOffsetPx(kernel.offsetMm[k], 0.5f * fy, c.w);
                    glm::vec3 s(c);
                    if (qy >= 0 && qy < hh) {
                        const glm::vec4 t = first[static_cast<std::size_t>(qy) * hw + x];
                        if (glsl::scatterAccepts(c.w, t.w, kernel.offsetMm[k])) s = glm::vec3(t);
                    }
                    sum += weight(k) * s;
                }
            }
            second[static_cast<std::size_t>(y) * hw + x] = glm::vec4(sum, c.w);
        }
    // Pass 2: full size, the half-size result upsampled by depth.
    std::vector<float> out(3 * n);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            const glm::vec3 c = body(x, y);
            const float spec = bodySpecular[4 * i + 3];
            const float zc = depthAt(x, y);
            glm::vec3 scattered = c;
            if (zc > 0.0f) {
                const glm::vec2 hp =
                    (glm::vec2(static_cast<float>(x), static_cast<float>(y)) + glm::vec2(0.5f)) * 0.5f -
                    glm::vec2(0.5f);
                const glm::ivec2 i0(glm::floor(hp));
                const glm::vec2 f = hp - glm::floor(hp);
                glm::vec3 sum(0.0f);
                float weights = 0.0f;
                for (int k = 0; k < 4; ++k) {
                    const int dx = k & 1, dy = k >> 1;
                    const int qx = std::clamp(i0.x + dx, 0, hw - 1), qy = std::clamp(i0.y + dy, 0, hh - 1);
                    const glm::vec4 t = second[static_cast<std::size_t>(qy) * hw + qx];
                    const float wk = glsl::scatterBilinear(f, dx, dy);
                    if (wk > 0.0f && glsl::scatterAccepts(zc, t.w, glsl::scatterUpsampleMm(zc, fx))) {
                        sum += wk * glm::vec3(t);
                        weights += wk;
                    }
                }
                if (weights > 0.0f) scattered = sum / weights;
            }
            const glm::vec3 r = glsl::scatterMix(scattered, c, share) + glm::vec3(spec);
            out[3 * i] = r.x, out[3 * i + 1] = r.y, out[3 * i + 2] = r.z;
        }
    return out;
}

}  // namespace mucosa::shading
