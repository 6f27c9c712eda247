// The endoscope lens models: see include/mucosa/dataset/lens.hpp.
//
// Where each convention comes from:
//  - Pinhole: OpenCV's calib3d camera model (x' = x/z, r^2 = x'^2 + y'^2,
//    x'' = x' (1 + k1 r^2 + k2 r^4), u = fx x'' + cx); Brown 1966. The same
//    arithmetic as frames::project.
//  - Fisheye: OpenCV's calib3d "Fisheye camera model" (namespace cv::fisheye):
//    a = x/z, b = y/z, r = |(a, b)|, theta = atan(r), theta_d = theta (1 + k1
//    theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8), x' = (theta_d / r) a,
//    u = fx (x' + alpha y') + cx with alpha = 0 here. Kannala & Brandt 2006,
//    eq. 6, truncated to OpenCV's four terms. theta is computed as
//    atan2(|(x, y)|, z), the angle from the optical axis, which equals
//    atan(r) in front of the camera and continues past 90 degrees.
//  - Omnidirectional: Scaramuzza, Martinelli & Siegwart 2006 (ICVS, "A
//    Flexible Technique for Accurate Omnidirectional Camera Calibration and
//    Structure from Motion"): the ray of an image point at (x', y') from the
//    centre is (x', y', f(rho)), f a polynomial in rho = |(x', y')|, and the
//    sensor's misalignment an affine map [c d; e 1]. The conventions of the
//    numbers OCamCalib ships are those of its C interface, ocam_functions.c
//    and ocam_functions.h (Scaramuzza 2009):
//      * cam2world: (x', y') = [c d; e 1]^-1 (point2D - (xc, yc)), ray
//        (x', y', pol(rho)) normalised, pol[0] the constant term;
//      * world2cam: theta = atan(z / |(x, y)|), rho = invpol(theta) (invpol[0]
//        the constant term), point2D = [c d; e 1] rho (x, y) / |(x, y)| +
//        (xc, yc);
//      * point2D = [rows; cols], "xc: row coordinate of the center, yc:
//        column coordinate", coordinates "start from 0 instead than from 1"
//        (the header's comments; calib_results.txt's own comment line says
//        the centre is "row" and "column", "starting from 0 (C convention)");
//      * create_perspecive_undistortion_LUT builds cv::remap maps with the
//        column as map x and the row as map y, from world2cam of points at
//        z = -width / sf < 0: the scene is at NEGATIVE z, OCamCalib's columns
//        are OpenCV's u with the same integer pixel centres;
//      * get_ocam_model reads the file's last line as "height width";
//      * the toolbox's findinvpoly.m fits invpol to pol's inverse within 0.01
//        px, over rho below half the image's diagonal.
//    So OCamCalib's frame is (x, y, z)_ocam = (y, x, -z)_OpenCV: x along the
//    rows (down), y along the columns (right), z backwards; a rotation by
//    half a turn about the axis (1, 1, 0) / sqrt 2, determinant +1.
#include <mucosa/dataset/lens.hpp>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <numbers>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>

#include "core/json_parse.hpp"

namespace mucosa::dataset {

using json = nlohmann::json;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxSize = 65536;          // width and height, as frames files
constexpr int kMaxCoefficients = 64;     // OCamCalib's MAX_POL_LENGTH
constexpr int kFoldSamples = 4096;       // where a model's slope is searched for its first zero
constexpr double kInvpolTolerance = 1;   // px; OCamCalib's own invpol is within 0.01 px
constexpr double kOmniRadiusMargin = 1;  // px beyond the image's farthest corner

// A polynomial with its constant first (OCamCalib's order), by Horner's rule.
double polyval(const std::vector<double>& a, double x) noexcept {
    double p = 0;
    for (auto it = a.rbegin(); it != a.rend(); ++it) p = p * x + *it;
    return p;
}

// The polynomial and its derivative.
std::pair<double, double> polyvalSlope(const std::vector<double>& a, double x) noexcept {
    double p = 0, dp = 0;
    for (auto it = a.rbegin(); it != a.rend(); ++it) {
        dp = dp * x + p;
        p = p * x + *it;
    }
    return {p, dp};
}

struct ValueSlope {
    double value, slope;
};

// The root of f on [lo, hi], where f(lo) <= 0 <= f(hi) and f has one root:
// Newton's method from x, safeguarded as Numerical Recipes' rtsafe (3rd ed.,
// sec. 9.4): it bisects the bracket, which shrinks with every evaluation,
// whenever a Newton step would leave it or would not halve the step before
// (far from the root of a steep polynomial Newton crawls).
template <class F>
double solveBracketed(F f, double lo, double hi, double x) noexcept {
    if (!(x > lo && x < hi)) x = 0.5 * (lo + hi);
    double step = hi - lo, stepBefore = step;
    for (int i = 0; i < kLensMaxIterations; ++i) {
        const ValueSlope g = f(x);
        if (g.value == 0) return x;
        (g.value < 0 ? lo : hi) = x;
        const double newton = g.value / g.slope;
        const double tolerance = kLensTolerance * std::max(1.0, std::abs(x));
        // Converged, also when x - newton rounds to x (which the bracket test
        // below would take for a step out of the bracket).
        if (g.slope > 0 && std::abs(newton) <= tolerance) return x - newton;
        double next = x - newton;
        if (!(next > lo && next < hi) || !(std::abs(2 * newton) <= std::abs(stepBefore))) next = 0.5 * (lo + hi);
        stepBefore = step;
        step = next - x;
        if (std::abs(step) <= tolerance) return next;
        x = next;
    }
    return x;
}

// The first zero of a slope that is positive at 0, searched on (0, hi]:
// the largest x found below it where the slope is still positive, or
// infinity when the slope stays positive up to hi. Sampled (kFoldSamples
// steps), then bisected to the last bit.
template <class Slope>
double firstFold(Slope slope, double hi) {
    double prev = 0;
    for (int i = 1; i <= kFoldSamples; ++i) {
        const double x = hi * i / kFoldSamples;
        if (!(slope(x) > 0)) {
            double a = prev, b = x;
            for (int k = 0; k < 200; ++k) {
                const double mid = 0.5 * (a + b);
                if (mid <= a || mid >= b) break;
                (slope(mid) > 0 ? a : b) = mid;
            }
            return a;
        }
        prev = x;
    }
    return kInf;
}

// Brown: the smallest s = r^2 > 0 where d r_d / d r = 1 + 3 k1 s + 5 k2 s^2
// is 0, or infinity. The quadratic's roots as Numerical Recipes (3rd ed.,
// sec. 5.6) takes them, without cancellation.
double brownFold(double k1, double k2) noexcept {
    const double A = 5 * k2, B = 3 * k1;
    if (A == 0) return B < 0 ? -1 / B : kInf;
    const double disc = B * B - 4 * A;
    if (disc < 0) return kInf;
    const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
    double best = kInf;
    for (const double s : {q / A, 1 / q})
        if (s > 0 && s < best) best = s;
    return best;
}

double kannalaBrandt(const Lens& L, double theta) noexcept {
    const double t2 = theta * theta;
    return theta * (1 + t2 * (L.k1 + t2 * (L.k2 + t2 * (L.k3 + t2 * L.k4))));
}

double kannalaBrandtSlope(const Lens& L, double theta) noexcept {
    const double t2 = theta * theta;
    return 1 + t2 * (3 * L.k1 + t2 * (5 * L.k2 + t2 * (7 * L.k3 + t2 * 9 * L.k4)));
}

// OCamCalib's (x', y') of a pixel: the affine part undone (cam2world).
std::array<double, 2> omniPlane(const Lens& L, double u, double v) noexcept {
    const double row = v - L.xc, col = u - L.yc;
    const double det = L.c - L.d * L.e;
    return {(row - L.d * col) / det, (-L.e * row + L.c * col) / det};
}

// rho beyond which the omnidirectional model is not used: the image's
// farthest corner (the outer edges of its corner pixels) plus a margin.
double omniRadiusCap(const Lens& L) noexcept {
    double far = 0;
    for (const double u : {-0.5, L.width - 0.5})
        for (const double v : {-0.5, L.height - 0.5}) {
            const auto [x, y] = omniPlane(L, u, v);
            far = std::max(far, std::hypot(x, y));
        }
    return far + kOmniRadiusMargin;
}

// The ray's angle from the optical axis at rho: atan2(rho, -pol(rho)).
double omniAngle(const Lens& L, double rho) noexcept {
    return std::atan2(rho, -polyval(L.pol, rho));
}

// The rho where the ray's angle from the axis is theta (0 < theta <
// thetaMax). The ray at rho, (forward, radial) = (-pol(rho), rho), is at
// angle phi(rho) from the axis, and g(rho) = rho cos theta + pol(rho) sin
// theta = |ray| sin(phi - theta) has the sign of phi - theta, so its one
// root on [0, rho_max] is the rho sought. invpol, when given, starts Newton
// next to it.
double omniRadius(const Lens& L, double theta, bool seedWithInvpol) noexcept {
    const double s = std::sin(theta), co = std::cos(theta);
    const double seed = seedWithInvpol && !L.invpol.empty() ? polyval(L.invpol, theta - 0.5 * kPi) : -1;
    return solveBracketed(
        [&](double rho) {
            const auto [p, dp] = polyvalSlope(L.pol, rho);
            return ValueSlope{rho * co + p * s, co + dp * s};
        },
        0, L.limits.inner, seed);
}

// The limits of a lens whose parameters validateLens accepts (0 where they
// are not usable).
LensLimits computeLimits(const Lens& L) {
    LensLimits lim;
    switch (L.model) {
        case LensModel::Pinhole: {
            const double s = brownFold(L.k1, L.k2);
            if (s == kInf) {
                lim = {0.5 * kPi, kInf, kInf};
            } else {
                const double r = std::sqrt(s);
                lim = {std::atan(r), r, r * (1 + L.k1 * s + L.k2 * s * s)};
            }
            break;
        }
        case LensModel::Fisheye: {
            const double theta = std::min(firstFold([&](double t) { return kannalaBrandtSlope(L, t); }, kPi), kPi);
            lim = {theta, theta, kannalaBrandt(L, theta)};
            break;
        }
        case LensModel::Omnidirectional: {
            if (L.pol.empty() || !(L.pol[0] < 0) || !(L.c - L.d * L.e > 0)) return lim;
            // d phi / d rho = (rho pol'(rho) - pol(rho)) / (rho^2 + pol^2).
            const double cap = omniRadiusCap(L);
            const double fold = firstFold(
                [&](double rho) {
                    const auto [p, dp] = polyvalSlope(L.pol, rho);
                    return rho * dp - p;
                },
                cap);
            const double rho = std::min(fold, cap);
            lim = {omniAngle(L, rho), rho, rho};
            break;
        }
    }
    return lim;
}

void requireLimits(const Lens& L) {
    MUCOSA_CHECK(L.limits.thetaMax > 0, "a dataset::Lens used before validateLens() derived its limits");
}

}  // namespace

const char* lensModelName(LensModel model) noexcept {
    switch (model) {
        case LensModel::Pinhole:
            return "pinhole";
        case LensModel::Fisheye:
            return "fisheye";
        case LensModel::Omnidirectional:
            return "omnidirectional";
    }
    return "";
}

double maxFieldAngle(const Lens& lens) {
    return computeLimits(lens).thetaMax;
}

void validateLens(Lens& L, const std::string& file, const std::string& where) {
    auto bad = [&](const std::string& field, const std::string& why) {
        return InputError("field '" + where + field + "'", file, why);
    };
    auto finite = [&](double value, const char* field) {
        if (!std::isfinite(value)) throw bad(field, "must be a finite number");
    };
    if (L.width < 1 || L.width > kMaxSize) throw bad("width", fmt::format("must be 1 to {} pixels", kMaxSize));
    if (L.height < 1 || L.height > kMaxSize) throw bad("height", fmt::format("must be 1 to {} pixels", kMaxSize));
    switch (L.model) {
        case LensModel::Pinhole:
        case LensModel::Fisheye:
            finite(L.fx, "fx");
            finite(L.fy, "fy");
            if (!(L.fx > 0)) throw bad("fx", "focal lengths must be positive");
            if (!(L.fy > 0)) throw bad("fy", "focal lengths must be positive");
            finite(L.cx, "cx");
            finite(L.cy, "cy");
            finite(L.k1, "k1");
            finite(L.k2, "k2");
            finite(L.k3, "k3");
            finite(L.k4, "k4");
            if (L.model == LensModel::Pinhole) {
                if (L.k3 != 0) throw bad("k3", "is not a pinhole parameter (Brown k1, k2 only)");
                if (L.k4 != 0) throw bad("k4", "is not a pinhole parameter (Brown k1, k2 only)");
            }
            break;
        case LensModel::Omnidirectional: {
            if (L.pol.empty() || L.pol.size() > std::size_t{kMaxCoefficients})
                throw bad("pol", fmt::format("must have 1 to {} coefficients", kMaxCoefficients));
            if (L.invpol.size() > std::size_t{kMaxCoefficients})
                throw bad("invpol", fmt::format("must have at most {} coefficients", kMaxCoefficients));
            for (const double a : L.pol)
                if (!std::isfinite(a)) throw bad("pol", "must hold finite numbers");
            for (const double a : L.invpol)
                if (!std::isfinite(a)) throw bad("invpol", "must hold finite numbers");
            if (!(L.pol[0] < 0))
                throw bad("pol", fmt::format("a0 = {} must be negative: OCamCalib's rays are (x, y, pol(rho)) with the "
                                             "scene at negative z (a positive a0 is another tool's convention)",
                                             L.pol[0]));
            finite(L.xc, "xc");
            finite(L.yc, "yc");
            finite(L.c, "c");
            finite(L.d, "d");
            finite(L.e, "e");
            if (!(L.c - L.d * L.e > 0))
                throw bad("c", fmt::format("the affine [c d; e 1] has determinant c - d e = {}: it must be positive "
                                           "(0 is singular, negative mirrors the image)",
                                           L.c - L.d * L.e));
            break;
        }
    }
    L.limits = computeLimits(L);
    if (!(L.limits.thetaMax > 0)) throw bad("model", "the lens maps no ray one to one");
    if (L.model == LensModel::Omnidirectional && !L.invpol.empty()) {
        // invpol only seeds Newton, but one far from pol's inverse means the
        // file was misread (a reversed order, the wrong line).
        const double rhoCheck = std::min(L.limits.inner, 0.5 * std::hypot(L.width, L.height));
        const double thetaCheck = omniAngle(L, rhoCheck);
        double worst = 0, worstTheta = 0;
        constexpr int kChecks = 256;
        for (int i = 1; i <= kChecks; ++i) {
            const double theta = thetaCheck * i / kChecks;
            const double err = std::abs(polyval(L.invpol, theta - 0.5 * kPi) - omniRadius(L, theta, false));
            if (!(err <= worst)) {
                worst = err;
                worstTheta = theta;
            }
        }
        if (!(worst <= kInvpolTolerance))
            throw bad("invpol", fmt::format("is {:.3g} px from the inverse of pol at {:.1f} degrees from the axis "
                                            "(OCamCalib's is within 0.01 px): are its coefficients in the file's "
                                            "order, constant first?",
                                            worst, worstTheta * 180 / kPi));
    }
}

std::optional<PixelPoint> project(const Lens& L, const Vec3d& P) {
    requireLimits(L);
    const double X = P[0], Y = P[1], Z = P[2];
    switch (L.model) {
        case LensModel::Pinhole: {
            if (!(Z > 0)) return std::nullopt;
            const double x = X / Z, y = Y / Z;
            const double r2 = x * x + y * y;
            if (!(r2 < L.limits.inner * L.limits.inner)) return std::nullopt;
            const double s = 1.0 + L.k1 * r2 + L.k2 * r2 * r2;  // Brown, as frames::project
            return PixelPoint{L.fx * x * s + L.cx, L.fy * y * s + L.cy};
        }
        case LensModel::Fisheye: {
            const double r = std::sqrt(X * X + Y * Y);
            if (r == 0) return Z > 0 ? std::optional(PixelPoint{L.cx, L.cy}) : std::nullopt;
            const double theta = std::atan2(r, Z);
            if (!(theta < L.limits.thetaMax)) return std::nullopt;
            const double s = kannalaBrandt(L, theta) / r;
            return PixelPoint{L.fx * X * s + L.cx, L.fy * Y * s + L.cy};
        }
        case LensModel::Omnidirectional: {
            const double r = std::sqrt(X * X + Y * Y);
            if (r == 0) return Z > 0 ? std::optional(PixelPoint{L.yc, L.xc}) : std::nullopt;
            const double theta = std::atan2(r, Z);
            if (!(theta < L.limits.thetaMax)) return std::nullopt;
            const double rho = omniRadius(L, theta, true);
            // world2cam in OCamCalib's frame: its (x, y) is Mucosa's (y, x).
            const double xo = Y / r * rho, yo = X / r * rho;
            const double row = L.c * xo + L.d * yo + L.xc;
            const double col = L.e * xo + yo + L.yc;
            return PixelPoint{col, row};
        }
    }
    return std::nullopt;
}

std::optional<Vec3d> unproject(const Lens& L, double u, double v) {
    requireLimits(L);
    switch (L.model) {
        case LensModel::Pinhole: {
            const double xd = (u - L.cx) / L.fx, yd = (v - L.cy) / L.fy;
            const double rd = std::sqrt(xd * xd + yd * yd);
            if (rd == 0) return Vec3d{0, 0, 1};
            if (!(rd < L.limits.outer)) return std::nullopt;
            auto f = [&](double r) {
                const double r2 = r * r;
                return ValueSlope{r * (1 + L.k1 * r2 + L.k2 * r2 * r2) - rd, 1 + 3 * L.k1 * r2 + 5 * L.k2 * r2 * r2};
            };
            double hi = L.limits.inner;
            if (hi == kInf) {  // no fold: r_d grows without bound, so doubling brackets the root
                hi = rd;
                for (int i = 0; f(hi).value < 0; ++i) {
                    if (i == 2100 || !std::isfinite(hi)) return std::nullopt;
                    hi *= 2;
                }
            }
            const double r = solveBracketed(f, 0, hi, rd);
            const double x = xd * (r / rd), y = yd * (r / rd);
            const double n = std::sqrt(x * x + y * y + 1);
            return Vec3d{x / n, y / n, 1 / n};
        }
        case LensModel::Fisheye: {
            const double a = (u - L.cx) / L.fx, b = (v - L.cy) / L.fy;
            const double thetaD = std::sqrt(a * a + b * b);
            if (thetaD == 0) return Vec3d{0, 0, 1};
            if (!(thetaD < L.limits.outer)) return std::nullopt;
            const double theta = solveBracketed(
                [&](double t) {
                    return ValueSlope{kannalaBrandt(L, t) - thetaD, kannalaBrandtSlope(L, t)};
                },
                0, L.limits.inner, thetaD);
            const double s = std::sin(theta) / thetaD;
            return Vec3d{a * s, b * s, std::cos(theta)};
        }
        case LensModel::Omnidirectional: {
            const auto [x, y] = omniPlane(L, u, v);
            const double rho = std::sqrt(x * x + y * y);
            if (!(rho < L.limits.inner)) return std::nullopt;
            const double z = polyval(L.pol, rho);  // cam2world: the ray (x, y, z) in OCamCalib's frame
            const double n = std::sqrt(x * x + y * y + z * z);
            return Vec3d{y / n, x / n, -z / n};
        }
    }
    return std::nullopt;
}

Lens fromIntrinsics(const frames::Intrinsics& K) {
    Lens L;
    L.model = LensModel::Pinhole;
    L.width = K.width;
    L.height = K.height;
    L.fx = K.fx;
    L.fy = K.fy;
    L.cx = K.cx;
    L.cy = K.cy;
    L.k1 = K.k1;
    L.k2 = K.k2;
    validateLens(L, "", "intrinsics.");
    return L;
}

Lens equidistantFisheye(int width, int height, double fieldOfViewDeg, FieldOfViewSpan span) {
    if (!(fieldOfViewDeg > 0 && fieldOfViewDeg < 360))
        throw InputError("field of view", "",
                         fmt::format("{} degrees: must be more than 0 and less than 360", fieldOfViewDeg));
    if (width < 1 || width > kMaxSize || height < 1 || height > kMaxSize)
        throw InputError("size", "",
                         fmt::format("{}x{}: width and height must be 1 to {} pixels", width, height, kMaxSize));
    // The outer edge of the corner (or the leftmost) pixel is half a pixel
    // beyond its centre: the half-diagonal (half-width) in pixels.
    const double half = span == FieldOfViewSpan::Diagonal ? 0.5 * std::hypot(width, height) : 0.5 * width;
    const double f = half / (0.5 * fieldOfViewDeg * kPi / 180);  // equidistant: r = f theta
    Lens L;
    L.model = LensModel::Fisheye;
    L.width = width;
    L.height = height;
    L.fx = L.fy = f;
    L.cx = 0.5 * (width - 1);
    L.cy = 0.5 * (height - 1);
    validateLens(L);
    return L;
}

// --- JSON -------------------------------------------------------------------

namespace {

double jsonNumber(const json& j, const char* key, const std::string& where, const std::string& file, bool required,
                  double fallback = 0) {
    const std::string field = "field '" + where + key + "'";
    if (!j.contains(key)) {
        if (required) throw InputError(field, file, "is missing");
        return fallback;
    }
    if (!j[key].is_number()) throw InputError(field, file, "must be a number");
    const double v = j[key].get<double>();
    if (!std::isfinite(v)) throw InputError(field, file, "must be finite");
    return v;
}

std::vector<double> jsonCoefficients(const json& j, const char* key, const std::string& where, const std::string& file,
                                     bool required) {
    const std::string field = where + key;
    if (!j.contains(key)) {
        if (required) throw InputError("field '" + field + "'", file, "is missing");
        return {};
    }
    const json& a = j[key];
    if (!a.is_array()) throw InputError("field '" + field + "'", file, "must be an array of numbers, constant first");
    std::vector<double> out;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (!a[i].is_number() || !std::isfinite(a[i].get<double>()))
            throw InputError(fmt::format("field '{}[{}]'", field, i), file, "must be a finite number");
        out.push_back(a[i].get<double>());
    }
    return out;
}

}  // namespace

Lens lensFromJson(const json& j, const std::string& file, const std::string& where) {
    if (!j.is_object())
        throw InputError(where.empty() ? "lens" : "field '" + where.substr(0, where.size() - 1) + "'", file,
                         "must be a JSON object");
    const std::string modelField = "field '" + where + "model'";
    if (!j.contains("model")) throw InputError(modelField, file, "is missing (pinhole, fisheye or omnidirectional)");
    if (!j["model"].is_string()) throw InputError(modelField, file, "must be a string");
    const std::string name = j["model"].get<std::string>();
    Lens L;
    std::set<std::string> known = {"model", "width", "height"};
    if (name == "pinhole" || name == "fisheye") {
        L.model = name == "pinhole" ? LensModel::Pinhole : LensModel::Fisheye;
        known.insert({"fx", "fy", "cx", "cy", "k1", "k2"});
        if (L.model == LensModel::Fisheye) known.insert({"k3", "k4"});
    } else if (name == "omnidirectional") {
        L.model = LensModel::Omnidirectional;
        known.insert({"pol", "invpol", "xc", "yc", "c", "d", "e"});
    } else {
        throw InputError(modelField, file, "'" + name + "' is not a lens model (pinhole, fisheye or omnidirectional)");
    }
    for (const auto& item : j.items())
        if (!known.contains(item.key())) {
            std::string list;
            for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
            throw InputError("field '" + where + item.key() + "'", file,
                             "is not a parameter of the " + name + " model (" + list + ")");
        }
    for (const char* key : {"width", "height"}) {
        if (!j.contains(key)) throw InputError("field '" + where + key + "'", file, "is missing");
        (std::string_view(key) == "width" ? L.width : L.height) =
            detail::wholeNumber<int>(j[key], where + key, file, 1, kMaxSize);
    }
    if (L.model == LensModel::Omnidirectional) {
        L.pol = jsonCoefficients(j, "pol", where, file, true);
        L.invpol = jsonCoefficients(j, "invpol", where, file, false);
        L.xc = jsonNumber(j, "xc", where, file, true);
        L.yc = jsonNumber(j, "yc", where, file, true);
        L.c = jsonNumber(j, "c", where, file, false, 1);
        L.d = jsonNumber(j, "d", where, file, false, 0);
        L.e = jsonNumber(j, "e", where, file, false, 0);
    } else {
        L.fx = jsonNumber(j, "fx", where, file, true);
        L.fy = jsonNumber(j, "fy", where, file, true);
        L.cx = jsonNumber(j, "cx", where, file, true);
        L.cy = jsonNumber(j, "cy", where, file, true);
        L.k1 = jsonNumber(j, "k1", where, file, false);
        L.k2 = jsonNumber(j, "k2", where, file, false);
        L.k3 = jsonNumber(j, "k3", where, file, false);
        L.k4 = jsonNumber(j, "k4", where, file, false);
    }
    validateLens(L, file, where);
    return L;
}

Lens readLens(const std::filesystem::path& path) {
    const std::string file = path.string();
    return lensFromJson(detail::parseJsonFile(readTextFile(path), file), file);
}

json lensJson(const Lens& L) {
    json j = {{"model", lensModelName(L.model)}, {"width", L.width}, {"height", L.height}};
    switch (L.model) {
        case LensModel::Pinhole:
        case LensModel::Fisheye:
            j["fx"] = L.fx;
            j["fy"] = L.fy;
            j["cx"] = L.cx;
            j["cy"] = L.cy;
            j["k1"] = L.k1;
            j["k2"] = L.k2;
            if (L.model == LensModel::Fisheye) {
                j["k3"] = L.k3;
                j["k4"] = L.k4;
            }
            break;
        case LensModel::Omnidirectional:
            j["pol"] = L.pol;
            if (!L.invpol.empty()) j["invpol"] = L.invpol;
            j["xc"] = L.xc;
            j["yc"] = L.yc;
            j["c"] = L.c;
            j["d"] = L.d;
            j["e"] = L.e;
            break;
    }
    return j;
}

// --- OCamCalib's calib_results.txt ------------------------------------------

namespace {

struct Token {
    std::string_view text;
    int column = 1;  // 1-based
};

struct DataLine {
    int number = 0;  // 1-based
    std::vector<Token> tokens;
};

std::vector<Token> splitTokens(std::string_view line) {
    std::vector<Token> out;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
        const std::size_t start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
        if (i > start) out.push_back({line.substr(start, i - start), static_cast<int>(start) + 1});
    }
    return out;
}

}  // namespace

Lens parseOcamCalib(std::string_view text, const std::string& file) {
    // What each of the five lines of numbers holds (get_ocam_model's order).
    static constexpr std::array<const char*, 5> kWhat = {"pol", "invpol", "centre", "affine", "image size"};
    std::vector<DataLine> lines;
    int number = 0;
    for (std::size_t start = 0; start <= text.size();) {
        std::size_t end = text.find('\n', start);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(start, end - start);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        ++number;
        std::vector<Token> tokens = splitTokens(line);
        if (!tokens.empty() && tokens[0].text[0] != '#') {
            if (lines.size() == kWhat.size())
                throw InputError("OCamCalib calibration", file, number, tokens[0].column,
                                 "unexpected numbers after the image size (the file has five lines of numbers: pol, "
                                 "invpol, centre, affine, image size)");
            lines.push_back({number, std::move(tokens)});
        }
        start = end + 1;
    }
    if (lines.size() < kWhat.size())
        throw InputError("OCamCalib calibration", file,
                         fmt::format("has {} lines of numbers where calib_results.txt has 5: pol, invpol, the centre "
                                     "(row column), the affine (c d e), the image size (height width)",
                                     lines.size()));

    std::array<std::vector<double>, 5> values;
    for (std::size_t k = 0; k < lines.size(); ++k)
        for (const Token& t : lines[k].tokens) {
            double x = 0;
            const auto [end, ec] = std::from_chars(t.text.data(), t.text.data() + t.text.size(), x);
            if (ec != std::errc() || end != t.text.data() + t.text.size() || !std::isfinite(x))
                throw InputError(kWhat[k], file, lines[k].number, t.column,
                                 "'" + std::string(t.text) + "' is not a finite number");
            values[k].push_back(x);
        }
    auto at = [&](std::size_t k, std::size_t token, const std::string& why) {
        const auto& tokens = lines[k].tokens;
        const int column = token < tokens.size() ? tokens[token].column : 1;
        return InputError(kWhat[k], file, lines[k].number, column, why);
    };
    std::array<std::vector<double>, 2> polys;
    for (std::size_t k = 0; k < 2; ++k) {
        const double count = values[k][0];
        if (count != std::floor(count) || count < 1 || count > kMaxCoefficients)
            throw at(k, 0,
                     fmt::format("the line starts with the count of coefficients, 1 to {}, not {}", kMaxCoefficients,
                                 lines[k].tokens[0].text));
        if (values[k].size() - 1 != static_cast<std::size_t>(count))
            throw at(k, std::min(values[k].size(), static_cast<std::size_t>(count) + 1),
                     fmt::format("has {} coefficients after the count {}", values[k].size() - 1, count));
        polys[k].assign(values[k].begin() + 1, values[k].end());
    }
    if (values[2].size() != 2) throw at(2, 2, "must be two numbers: the centre's row and column");
    if (values[3].size() != 3) throw at(3, 3, "must be three numbers: c, d, e");
    if (values[4].size() != 2) throw at(4, 2, "must be two numbers: height and width");
    for (std::size_t i = 0; i < 2; ++i) {
        const double size = values[4][i];
        if (size != std::floor(size) || size < 1 || size > kMaxSize)
            throw at(
                4, i,
                fmt::format("the {} must be a whole number of pixels, 1 to {}", i == 0 ? "height" : "width", kMaxSize));
    }

    Lens L;
    L.model = LensModel::Omnidirectional;
    L.pol = std::move(polys[0]);
    L.invpol = std::move(polys[1]);
    L.xc = values[2][0];  // row
    L.yc = values[2][1];  // column
    L.c = values[3][0];
    L.d = values[3][1];
    L.e = values[3][2];
    L.height = static_cast<int>(values[4][0]);
    L.width = static_cast<int>(values[4][1]);
    try {
        validateLens(L, file);
    } catch (const InputError& e) {
        // Point at the line the refused value came from.
        const std::string& s = e.subject();
        const std::size_t k = s == "field 'pol'"                              ? 0
                              : s == "field 'invpol'"                         ? 1
                              : s == "field 'xc'" || s == "field 'yc'"        ? 2
                              : s == "field 'width'" || s == "field 'height'" ? 4
                                                                              : 3;
        throw InputError(kWhat[k], file, lines[k].number, 1, e.reason());
    }
    return L;
}

Lens readOcamCalib(const std::filesystem::path& path) {
    return parseOcamCalib(readTextFile(path), path.string());
}

Lens readLensFile(const std::filesystem::path& path) {
    return path.extension() == ".json" ? readLens(path) : readOcamCalib(path);
}

image::ImageF rayImage(const Lens& lens) {
    requireMemory(saturatingMul(static_cast<std::uint64_t>(lens.width) * static_cast<std::uint64_t>(lens.height), 12),
                  "the lens's rays");
    image::ImageF rays(lens.width, lens.height, 3);
    for (int y = 0; y < lens.height; ++y)
        for (int x = 0; x < lens.width; ++x)
            if (const std::optional<Vec3d> r = unproject(lens, x, y))
                for (int k = 0; k < 3; ++k) rays.at(x, y, k) = static_cast<float>((*r)[k]);
    return rays;
}

}  // namespace mucosa::dataset
