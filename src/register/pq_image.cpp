// The image side of pq-space registration: the (p, q) estimator (a local
// fit of the log-intensity's gradient, solved in closed form for the
// normal), pq from a frame's shading, and a frame prepared at every working
// level (Deligianni, Chung, Yang, MICCAI 2003; docs/theory.md "Registration").
// The model side runs the same estimator (model_view.cpp).
#include <mucosa/register/register.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include <mucosa/fit/fit.hpp>

#include "phases.hpp"

namespace mucosa::registration {

using detail::estimate;
using detail::openClose;
using detail::percentile;

namespace {

// Separable Gaussian with zero padding (the moments of the local fit).
void gaussianBlur(std::vector<double>& v, int w, int h, double sigma) {
    const int r = std::max(1, static_cast<int>(std::ceil(3 * sigma)));
    std::vector<double> k(2 * r + 1);
    double sum = 0;
    for (int i = -r; i <= r; ++i) sum += k[i + r] = std::exp(-0.5 * i * i / (sigma * sigma));
    for (double& x : k) x /= sum;
    std::vector<double> t(v.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double a = 0;
            for (int i = std::max(-r, -x); i <= std::min(r, w - 1 - x); ++i)
                a += k[i + r] * v[static_cast<std::size_t>(y) * w + x + i];
            t[static_cast<std::size_t>(y) * w + x] = a;
        }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double a = 0;
            for (int i = std::max(-r, -y); i <= std::min(r, h - 1 - y); ++i)
                a += k[i + r] * t[static_cast<std::size_t>(y + i) * w + x];
            v[static_cast<std::size_t>(y) * w + x] = a;
        }
}

// Grey-scale dilation (max) or erosion (min) over a (2r+1)^2 square of the
// usable pixels (separable); unusable pixels neither take part nor change.
void morphology(image::ImageF& img, const std::vector<std::uint8_t>& use, int r, bool dilate) {
    const int w = img.width(), h = img.height();
    const float none = dilate ? -std::numeric_limits<float>::infinity() : std::numeric_limits<float>::infinity();
    auto pick = [dilate](float a, float b) { return dilate ? std::max(a, b) : std::min(a, b); };
    std::vector<float> t(img.size(), none);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float v = none;
            for (int i = std::max(0, x - r); i <= std::min(w - 1, x + r); ++i) {
                const std::size_t j = static_cast<std::size_t>(y) * w + i;
                if (use[j]) v = pick(v, img.data()[j]);
            }
            t[static_cast<std::size_t>(y) * w + x] = v;
        }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t o = static_cast<std::size_t>(y) * w + x;
            if (!use[o]) continue;
            float v = none;
            for (int i = std::max(0, y - r); i <= std::min(h - 1, y + r); ++i)
                v = pick(v, t[static_cast<std::size_t>(i) * w + x]);
            if (std::isfinite(v)) img.data()[o] = v;
        }
}

// The closed-form solve: log-intensity derivatives (per unit of normalised
// image coordinate) at (x, y) -> the normal (a, b, -c) up to scale, with c =
// 1 + a x + b y (p = a / c, q = b / c), or nothing if masked. The normal is
// defined at any c (c = 0: a wall parallel to the optical axis, which looking
// down a bronchus is most of it); the mask is on the normal's cosine to the
// ray (x, y, 1), 1 / (|(a, b, c)| |(x, y, 1)|): grazing walls, occluding
// contours and folds, where the plane breaks. `grazing`: no mask (the
// model's side: a wall it sees is a wall, however it is seen).
std::optional<std::array<double, 3>> solvePq(double gx, double gy, double xn, double yn, const PqOptions& o,
                                             bool grazing = false) {
    const double S = 1 + xn * xn + yn * yn;
    const double a = -gx / 3 - xn / S, b = -gy / 3 - yn / S;
    const double c = 1 + a * xn + b * yn;
    if (!grazing && 1 / std::sqrt((a * a + b * b + c * c) * S) < o.minRayCosine) return std::nullopt;
    return std::array<double, 3>{a, b, c};
}

}  // namespace

namespace detail {

image::ImageF openClose(const image::ImageF& E, const std::vector<std::uint8_t>& use, int r) {
    image::ImageF f = E;
    if (r <= 0) return f;
    morphology(f, use, r, false);  // opening: erode ...
    morphology(f, use, r, true);   // ... then dilate
    morphology(f, use, r, true);   // closing: dilate ...
    morphology(f, use, r, false);  // ... then erode
    return f;
}

PqField estimate(const image::ImageF& E, std::vector<std::uint8_t> use, const frames::Intrinsics& K, const PqOptions& o,
                 double darkLevel, bool grazing) {
    const int w = E.width(), h = E.height();
    const std::size_t n = static_cast<std::size_t>(w) * h;
    PqField f;
    f.width = w;
    f.height = h;
    f.p.assign(n, 0.f);
    f.q.assign(n, 0.f);
    f.weight.assign(n, 0.f);
    f.normal.assign(n, {0.f, 0.f, 0.f});
    std::vector<float> L(n, 0.f);
    for (std::size_t i = 0; i < n; ++i) {
        const float e = E.data()[i];
        if (!(e > 0) || !std::isfinite(e)) use[i] = 0;
        if (use[i]) L[i] = std::log(e);
    }
    f.usable = use;
    // The log-intensity's gradient at each pixel: the slope of a plane fitted
    // to ln E by Gaussian-weighted least squares over the usable pixels around
    // it (a masked local-linear fit: unlike smoothing then differencing, it is
    // unbiased next to the mask's edge where the window is one-sided). The
    // moments come from separable convolutions of m, m x, m y, m x^2, m y^2,
    // m x y, m L, m L x, m L y (absolute coordinates, centred algebraically).
    enum { M1, MX, MY, MXX, MYY, MXY, ML, MLX, MLY, kMoments };
    std::vector<std::vector<double>> mom(kMoments, std::vector<double>(n, 0.0));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            if (!use[i]) continue;
            const double fx = x, fy = y;
            mom[M1][i] = 1, mom[MX][i] = fx, mom[MY][i] = fy, mom[MXX][i] = fx * fx, mom[MYY][i] = fy * fy;
            mom[MXY][i] = fx * fy, mom[ML][i] = L[i], mom[MLX][i] = L[i] * fx, mom[MLY][i] = L[i] * fy;
        }
    for (auto& m : mom) gaussianBlur(m, w, h, std::max(0.5, o.smoothingPx));
    const double fullMass = 1.0;  // the kernel is normalised
    const int b = std::max(1, o.borderPx);
    const double smoothing4 = std::pow(o.smoothingPx, 4);
    for (int y = b; y < h - b; ++y)
        for (int x = b; x < w - b; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            if (!use[i]) continue;
            const double s1 = mom[M1][i];
            if (s1 < 0.35 * fullMass) continue;                               // too little of the window is usable
            const double mx = mom[MX][i] / s1 - x, my = mom[MY][i] / s1 - y;  // centroid offset
            // Centred second moments (about the pixel) and cross-moments with L.
            const double sxx = mom[MXX][i] - 2.0 * x * mom[MX][i] + double(x) * x * s1;
            const double syy = mom[MYY][i] - 2.0 * y * mom[MY][i] + double(y) * y * s1;
            const double sxy = mom[MXY][i] - x * mom[MY][i] - y * mom[MX][i] + double(x) * y * s1;
            const double sl = mom[ML][i];
            const double slx = mom[MLX][i] - x * sl, sly = mom[MLY][i] - y * sl;
            // Normal equations of L ~ c + gu du + gv dv with du = u - x, dv = v - y.
            // The symmetric 3x3 system solved by its cofactors (c_ij), which
            // the determinant's test below needs anyway.
            const double a11 = s1, a12 = s1 * mx, a13 = s1 * my, a22 = sxx, a23 = sxy, a33 = syy;
            const double c11 = a22 * a33 - a23 * a23, c12 = a13 * a23 - a12 * a33, c13 = a12 * a23 - a13 * a22;
            const double det = a11 * c11 + a12 * c12 + a13 * c13;
            // A window cut to a line cannot give a 2D slope.
            if (std::abs(det) < 1e-3 * s1 * s1 * s1 * smoothing4) continue;
            const double c22 = a11 * a33 - a13 * a13, c23 = a12 * a13 - a11 * a23, c33 = a11 * a22 - a12 * a12;
            const double g1 = (c12 * sl + c22 * slx + c23 * sly) / det, g2 = (c13 * sl + c23 * slx + c33 * sly) / det;
            // d lnE / d(normalised x) = d lnE / du * fx.
            const double gx = g1 * K.fx, gy = g2 * K.fy;
            const auto abc = solvePq(gx, gy, (x - K.cx) / K.fx, (y - K.cy) / K.fy, o, grazing);
            if (!abc) continue;
            const auto [a, bb, cond] = *abc;
            const double held = std::max(cond, 0.01);  // p, q for display past the axis-parallel wall
            f.p[i] = static_cast<float>(a / held);
            f.q[i] = static_cast<float>(bb / held);
            const double norm = std::sqrt(a * a + bb * bb + cond * cond);
            f.normal[i] = {static_cast<float>(a / norm), static_cast<float>(bb / norm),
                           static_cast<float>(-cond / norm)};
            // Brightness: the log-gradient's noise grows as the signal falls.
            // (The model's side, noiseless, takes weight 1 wherever it has an estimate.)
            const double e = E.data()[i];
            f.weight[i] = grazing ? 1.f : static_cast<float>(e / (e + 2 * darkLevel));
        }
    return f;
}

double percentile(std::vector<float> v, double q) {
    if (v.empty()) return 0;
    const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

}  // namespace detail

PqField pqFromShading(const image::ImageF& linear, const frames::Intrinsics& K, const PqOptions& o,
                      const std::vector<std::uint8_t>* valid) {
    const std::size_t n = static_cast<std::size_t>(linear.width()) * linear.height();
    std::vector<float> inside;
    inside.reserve(n);
    for (std::size_t i = 0; i < n; ++i)
        if (!valid || (*valid)[i]) inside.push_back(linear.data()[i]);
    const double dark = o.darkFraction * percentile(inside, 0.99);
    std::vector<std::uint8_t> use(n);
    for (std::size_t i = 0; i < n; ++i) {
        const float e = linear.data()[i];
        use[i] = (!valid || (*valid)[i]) && e > dark && e < o.saturation;
    }
    const image::ImageF filtered = openClose(linear, use, o.albedoFilterPx);
    return estimate(filtered, std::move(use), K, o, dark);
}

VideoFrame prepareFrame(const image::ImageF& linear, const image::Image8* saturated, const frames::Intrinsics& K,
                        const RegisterOptions& o) {
    const int W = linear.width(), H = linear.height();
    // Luminance (Rec. 709 weights) and the scope's field of view.
    std::vector<float> lum(static_cast<std::size_t>(W) * H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const int c = linear.channels();
            const float r = linear.at(x, y, 0), g = linear.at(x, y, c > 1 ? 1 : 0), b = linear.at(x, y, c > 2 ? 2 : 0);
            lum[static_cast<std::size_t>(y) * W + x] = 0.2126f * r + 0.7152f * g + 0.0722f * b;
        }
    const std::vector<std::uint8_t> outside = fit::outsideFieldOfView(linear);

    VideoFrame f;
    for (int width : o.levels) {
        width = std::min(width, W);
        if (!f.levels.empty() && f.levels.back().K.width == width) continue;
        const double s = static_cast<double>(width) / W;
        VideoFrame::Level l;
        l.K.width = width;
        l.K.height = std::max(1, static_cast<int>(std::lround(H * s)));
        const double sy = static_cast<double>(l.K.height) / H;
        l.K.fx = K.fx * s;
        l.K.fy = K.fy * sy;
        l.K.cx = (K.cx + 0.5) * s - 0.5;
        l.K.cy = (K.cy + 0.5) * sy - 0.5;
        l.luminance = image::ImageF(l.K.width, l.K.height, 1);
        l.valid.assign(static_cast<std::size_t>(l.K.width) * l.K.height, 0);
        const int taps = std::clamp(static_cast<int>(std::ceil(1 / s)), 1, 4);
        for (int y = 0; y < l.K.height; ++y)
            for (int x = 0; x < l.K.width; ++x) {
                double sum = 0;
                bool ok = true;
                for (int j = 0; ok && j < taps; ++j)
                    for (int i = 0; ok && i < taps; ++i) {
                        const double u = x + (i + 0.5) / taps - 0.5, v = y + (j + 0.5) / taps - 0.5;
                        const auto px = frames::project(K, (u - l.K.cx) / l.K.fx, (v - l.K.cy) / l.K.fy);
                        const double fx = px[0], fy = px[1];
                        if (!(fx >= 0 && fy >= 0 && fx <= W - 1 && fy <= H - 1)) {
                            ok = false;
                            break;
                        }
                        const int x0 = std::min(W - 2, static_cast<int>(fx)),
                                  y0 = std::min(H - 2, static_cast<int>(fy));
                        const double ax = fx - x0, ay = fy - y0;
                        double acc = 0;
                        for (int dy = 0; dy < 2; ++dy)
                            for (int dx = 0; dx < 2; ++dx) {
                                const std::size_t k = static_cast<std::size_t>(y0 + dy) * W + x0 + dx;
                                const double wgt = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
                                if (wgt <= 0) continue;
                                if (outside[k] || (saturated && saturated->data()[k])) ok = false;
                                acc += wgt * lum[k];
                            }
                        sum += acc;
                    }
                const std::size_t i = static_cast<std::size_t>(y) * l.K.width + x;
                l.luminance.data()[i] = ok ? static_cast<float>(sum / (taps * taps)) : 0.f;
                l.valid[i] = ok && l.luminance.data()[i] < o.saturation;
            }
        // The albedo filter's radius is given in the frame's pixels.
        l.pqOptions = o.pq;
        l.pqOptions.albedoFilterPx = static_cast<int>(std::lround(o.albedoFilterPx * s));
        if (o.method == RegistrationMethod::PqSpace) l.pq = pqFromShading(l.luminance, l.K, l.pqOptions, &l.valid);
        f.levels.push_back(std::move(l));
    }
    return f;
}

}  // namespace mucosa::registration
