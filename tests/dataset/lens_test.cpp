// The endoscope lens models (include/mucosa/dataset/lens.hpp). Each model is
// checked against an implementation of its published formula written here,
// independently of lens.cpp and in the publication's own terms:
//  - pinhole: OpenCV's calib3d camera model with Brown k1, k2 (and
//    frames::project, the frames file's camera);
//  - fisheye: OpenCV's cv::fisheye model (a = x/z, theta = atan(r),
//    theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8), x' = theta_d a / r),
//    plus values worked out by hand;
//  - omnidirectional: OCamCalib's cam2world and world2cam (ocam_functions.c)
//    in its own frame (x along rows, y along columns, the scene at negative
//    z), its pixel as [row, col], powers summed as its C code does.
// Then: both round trips over the whole image and field (1e-9 px, 1e-9
// rad), the field limits, the preset, and the refusals of bad JSON and
// calib_results.txt files, each naming the field.
#include <mucosa/dataset/lens.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/frames/frames.hpp>

#include "test_support.hpp"

namespace mucosa::dataset {
namespace {

using json = nlohmann::json;
using test::TempDir;
namespace fs = std::filesystem;

constexpr double kPi = std::numbers::pi;
constexpr double kPixelTolerance = 1e-9;  // px
constexpr double kAngleTolerance = 1e-9;  // rad

// --- the lenses -------------------------------------------------------------

// A barrel-distorted pinhole (no fold: 1 + 3 k1 s + 5 k2 s^2 has no real root).
Lens pinholeLens() {
    Lens L;
    L.model = LensModel::Pinhole;
    L.width = 640;
    L.height = 480;
    L.fx = 500;
    L.fy = 510;
    L.cx = 321.25;
    L.cy = 238.75;
    L.k1 = -0.28;
    L.k2 = 0.07;
    validateLens(L);
    return L;
}

// A fisheye with all four Kannala-Brandt terms, off-centre.
Lens fisheyeLens() {
    Lens L;
    L.model = LensModel::Fisheye;
    L.width = 640;
    L.height = 480;
    L.fx = 250;
    L.fy = 252;
    L.cx = 322.3;
    L.cy = 237.9;
    L.k1 = 0.05;
    L.k2 = -0.012;
    L.k3 = 0.003;
    L.k4 = -0.0004;
    validateLens(L);
    return L;
}

// An OCamCalib lens at C3VD's size, off-centre with a clearly non-identity
// affine. pol is an equidistant lens (rho = f theta): the ray (rho, -rho
// cot(rho / f)), with u cot u = 1 - u^2/3 - u^4/45 - 2u^6/945 - u^8/4725 - ...
// truncated after u^8; so theta(rho) is close to rho / f and invpol, rho =
// f (theta_ocam + pi/2), is close to pol's inverse (the test measures how
// close).
constexpr double kOmniF = 700;
Lens omniLens() {
    Lens L;
    L.model = LensModel::Omnidirectional;
    L.width = 1350;
    L.height = 1080;
    const double f = kOmniF;
    L.pol = {-f,
             0,
             1 / (3 * f),
             0,
             1 / (45 * std::pow(f, 3)),
             0,
             2 / (945 * std::pow(f, 5)),
             0,
             1 / (4725 * std::pow(f, 7))};
    L.invpol = {f * kPi / 2, f};
    L.xc = 531.7;  // row
    L.yc = 688.2;  // column
    L.c = 1.03;
    L.d = 0.02;
    L.e = -0.015;
    validateLens(L);
    return L;
}

// --- independent implementations of the published formulas -----------------

// OpenCV's calib3d pinhole with Brown k1, k2 (p1 = p2 = k3 = 0).
std::array<double, 2> opencvPinhole(const Lens& L, const Vec3d& P) {
    const double x = P[0] / P[2], y = P[1] / P[2];
    const double r2 = x * x + y * y;
    const double radial = 1 + L.k1 * r2 + L.k2 * r2 * r2;
    return {L.fx * (x * radial) + L.cx, L.fy * (y * radial) + L.cy};
}

// OpenCV's fisheye model, term by term as its documentation writes it.
std::array<double, 2> opencvFisheye(const Lens& L, const Vec3d& P) {
    const double a = P[0] / P[2], b = P[1] / P[2];
    const double r = std::sqrt(a * a + b * b);
    const double theta = std::atan(r);
    const double thetaD = theta * (1 + L.k1 * std::pow(theta, 2) + L.k2 * std::pow(theta, 4) +
                                   L.k3 * std::pow(theta, 6) + L.k4 * std::pow(theta, 8));
    const double xp = r > 0 ? thetaD / r * a : 0, yp = r > 0 ? thetaD / r * b : 0;
    return {L.fx * xp + L.cx, L.fy * yp + L.cy};
}

// OCamCalib's polynomials: the sum of powers, as ocam_functions.c.
double sumOfPowers(const std::vector<double>& a, double x) {
    double sum = a[0], power = 1;
    for (std::size_t i = 1; i < a.size(); ++i) {
        power *= x;
        sum += power * a[i];
    }
    return sum;
}

// cam2world: point2D = [row, col] -> unit ray in OCamCalib's frame.
Vec3d cam2world(const Lens& L, double row, double col) {
    const double invdet = 1 / (L.c - L.d * L.e);
    const double xp = invdet * ((row - L.xc) - L.d * (col - L.yc));
    const double yp = invdet * (-L.e * (row - L.xc) + L.c * (col - L.yc));
    const double zp = sumOfPowers(L.pol, std::sqrt(xp * xp + yp * yp));
    const double invnorm = 1 / std::sqrt(xp * xp + yp * yp + zp * zp);
    return {invnorm * xp, invnorm * yp, invnorm * zp};
}

// world2cam's rho for its theta = atan(z / |(x, y)|): by invpol (as
// OCamCalib), or exactly, as the root of pol(rho) - rho tan(theta) (the
// equation OCamCalib's findinvpoly.m solves), found by bisection.
double rhoByInvpol(const Lens& L, double thetaOcam) {
    return sumOfPowers(L.invpol, thetaOcam);
}
double rhoExact(const Lens& L, double thetaOcam, double rhoMax) {
    const double m = std::tan(thetaOcam);
    double lo = 0, hi = rhoMax;  // pol(0) - 0 < 0 < pol(rhoMax) - rhoMax m on the lens's field
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        (sumOfPowers(L.pol, mid) - mid * m < 0 ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// world2cam: a point in OCamCalib's frame -> point2D = [row, col].
template <class Rho>
std::array<double, 2> world2cam(const Lens& L, const Vec3d& M, Rho rhoOf) {
    const double norm = std::sqrt(M[0] * M[0] + M[1] * M[1]);
    if (norm == 0) return {L.xc, L.yc};
    const double theta = std::atan(M[2] / norm);
    const double rho = rhoOf(theta);
    const double x = M[0] / norm * rho, y = M[1] / norm * rho;
    return {x * L.c + y * L.d + L.xc, x * L.e + y + L.yc};
}

// Mucosa (OpenCV axes) <-> OCamCalib: x_ocam = y, y_ocam = x, z_ocam = -z.
Vec3d toOcam(const Vec3d& P) {
    return {P[1], P[0], -P[2]};
}
Vec3d fromOcam(const Vec3d& M) {
    return {M[1], M[0], -M[2]};
}

// --- helpers ----------------------------------------------------------------

double angleBetween(const Vec3d& a, const Vec3d& b) {
    const Vec3d c{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    return std::atan2(std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
}

Vec3d direction(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

double norm(const Vec3d& v) {
    return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

struct RoundTrip {
    double worstPixel = 0;  // |project(unproject(p)) - p|, px
    double worstRay = 0;    // angle(unproject(project(d)), d), rad
    double worstNorm = 0;   // | |unproject(p)| - 1 |
    long pixels = 0, pixelsWithoutRay = 0, rays = 0;
};

// Every pixel centre and every pixel corner of the image; directions on a
// theta x phi grid up to `thetaFraction` of the field. `pixelsInside`: only
// the pixels whose rays are within that fraction too (where a model folds,
// the inverse is ill-conditioned next to the fold, for any implementation).
RoundTrip roundTrips(const Lens& L, double thetaFraction = 0.999, bool pixelsInside = false) {
    RoundTrip t;
    const double thetaMax = maxFieldAngle(L) * thetaFraction;
    for (int j = 0; j <= 2 * L.height; ++j)
        for (int i = 0; i <= 2 * L.width; ++i) {
            const double u = 0.5 * i - 0.5, v = 0.5 * j - 0.5;
            ++t.pixels;
            const auto ray = unproject(L, u, v);
            if (!ray) {
                ++t.pixelsWithoutRay;
                continue;
            }
            t.worstNorm = std::max(t.worstNorm, std::abs(norm(*ray) - 1));
            if (pixelsInside && angleBetween(*ray, {0, 0, 1}) > thetaMax) continue;
            const auto back = project(L, *ray);
            if (!back) {
                t.worstPixel = INFINITY;
                continue;
            }
            t.worstPixel = std::max(t.worstPixel, std::hypot(back->u - u, back->v - v));
        }
    for (int a = 0; a <= 600; ++a)
        for (int b = 0; b < 64; ++b) {
            const Vec3d d = direction(thetaMax * a / 600, 2 * kPi * (b + 0.37) / 64);
            ++t.rays;
            const auto px = project(L, d);
            const auto back = px ? unproject(L, px->u, px->v) : std::nullopt;
            t.worstRay = std::max(t.worstRay, back ? angleBetween(*back, d) : INFINITY);
        }
    return t;
}

// --- round trips ------------------------------------------------------------

TEST(LensRoundTrip, PinholeIsExactBothWaysOverImageAndField) {
    const RoundTrip t = roundTrips(pinholeLens());
    EXPECT_EQ(t.pixelsWithoutRay, 0);
    EXPECT_LE(t.worstPixel, kPixelTolerance);
    EXPECT_LE(t.worstRay, kAngleTolerance);
    EXPECT_LE(t.worstNorm, 1e-15);
    RecordProperty("worst_pixel", fmt::format("{:.3g}", t.worstPixel));
    RecordProperty("worst_ray", fmt::format("{:.3g}", t.worstRay));
}

TEST(LensRoundTrip, FisheyeIsExactBothWaysOverImageAndField) {
    const Lens L = fisheyeLens();
    const RoundTrip t = roundTrips(L);
    EXPECT_EQ(t.pixelsWithoutRay, 0);
    EXPECT_LE(t.worstPixel, kPixelTolerance);
    EXPECT_LE(t.worstRay, kAngleTolerance);
    EXPECT_LE(t.worstNorm, 1e-15);
    RecordProperty("worst_pixel", fmt::format("{:.3g}", t.worstPixel));
    RecordProperty("worst_ray", fmt::format("{:.3g}", t.worstRay));
}

TEST(LensRoundTrip, OmnidirectionalIsExactBothWaysOverImageAndField) {
    const RoundTrip t = roundTrips(omniLens());
    EXPECT_EQ(t.pixelsWithoutRay, 0);  // the field ends beyond the farthest corner
    EXPECT_LE(t.worstPixel, kPixelTolerance);
    EXPECT_LE(t.worstRay, kAngleTolerance);
    EXPECT_LE(t.worstNorm, 1e-15);
    RecordProperty("worst_pixel", fmt::format("{:.3g}", t.worstPixel));
    RecordProperty("worst_ray", fmt::format("{:.3g}", t.worstRay));
}

TEST(LensRoundTrip, PresetFisheyePastNinetyDegreesIsExact) {
    // 200 degrees across the diagonal: rays behind the image plane (z < 0).
    const Lens L = equidistantFisheye(400, 300, 200);
    const RoundTrip t = roundTrips(L);
    EXPECT_EQ(t.pixelsWithoutRay, 0);
    EXPECT_LE(t.worstPixel, kPixelTolerance);
    EXPECT_LE(t.worstRay, kAngleTolerance);
    const auto corner = unproject(L, -0.5, -0.5);
    ASSERT_TRUE(corner);
    EXPECT_LT((*corner)[2], 0);
}

TEST(LensRoundTrip, FoldedLensesAreExactInsideTheirField) {
    // Models that fold inside the image: the pixels beyond the fold have no
    // ray; everything inside round-trips.
    Lens pinhole = pinholeLens();
    pinhole.k1 = -0.35;
    pinhole.k2 = 0;
    validateLens(pinhole);
    Lens fisheye = fisheyeLens();
    fisheye.k1 = -0.1;
    fisheye.k2 = fisheye.k3 = fisheye.k4 = 0;
    fisheye.fx = fisheye.fy = 180;
    validateLens(fisheye);
    for (const Lens& L : {pinhole, fisheye}) {
        SCOPED_TRACE(lensModelName(L.model));
        const RoundTrip t = roundTrips(L, 0.99);
        EXPECT_GT(t.pixelsWithoutRay, 0);
        EXPECT_LE(t.worstPixel, kPixelTolerance);
        EXPECT_LE(t.worstRay, kAngleTolerance);
    }
}

// --- pinhole ----------------------------------------------------------------

TEST(LensPinhole, ProjectsAsOpenCvAndFitProject) {
    const Lens L = pinholeLens();
    frames::Intrinsics K;
    K.width = L.width;
    K.height = L.height;
    K.fx = L.fx;
    K.fy = L.fy;
    K.cx = L.cx;
    K.cy = L.cy;
    K.k1 = L.k1;
    K.k2 = L.k2;
    const Lens fromK = fromIntrinsics(K);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> xy(-0.8, 0.8), z(0.5, 120);
    for (int i = 0; i < 2000; ++i) {
        const double Z = z(rng);
        const Vec3d P{xy(rng) * Z, xy(rng) * Z, Z};
        const auto px = project(L, P);
        ASSERT_TRUE(px);
        const auto cv = opencvPinhole(L, P);
        EXPECT_NEAR(px->u, cv[0], kPixelTolerance);
        EXPECT_NEAR(px->v, cv[1], kPixelTolerance);
        const auto fit = frames::project(K, P[0] / P[2], P[1] / P[2]);
        EXPECT_EQ(px->u, fit[0]);  // the same arithmetic, bit for bit
        EXPECT_EQ(px->v, fit[1]);
        const auto again = project(fromK, P);
        ASSERT_TRUE(again);
        EXPECT_EQ(again->u, px->u);
        EXPECT_EQ(again->v, px->v);
    }
}

TEST(LensPinhole, NothingBehindTheLens) {
    const Lens L = pinholeLens();
    EXPECT_FALSE(project(L, {0.1, 0.2, 0}));
    EXPECT_FALSE(project(L, {0.1, 0.2, -1}));
    EXPECT_FALSE(project(L, {0, 0, 0}));
    EXPECT_DOUBLE_EQ(maxFieldAngle(L), kPi / 2);
}

TEST(LensPinhole, FieldEndsWhereBrownFolds) {
    // r_d = r (1 + k1 r^2) with k1 = -0.35 is largest at r^2 = 1 / (3 * 0.35).
    Lens L = pinholeLens();
    L.k1 = -0.35;
    L.k2 = 0;
    validateLens(L);
    const double rFold = std::sqrt(1 / 1.05);
    EXPECT_NEAR(maxFieldAngle(L), std::atan(rFold), 1e-15);
    const double thetaMax = std::atan(rFold);
    EXPECT_TRUE(project(L, direction(thetaMax * (1 - 1e-9), 0.3)));
    EXPECT_FALSE(project(L, direction(thetaMax * (1 + 1e-9), 0.3)));
    // Beyond the fold's image radius no pixel has a ray.
    const double rdMax = rFold * (1 - 0.35 * rFold * rFold);
    EXPECT_TRUE(unproject(L, L.cx + L.fx * rdMax * (1 - 1e-9), L.cy));
    EXPECT_FALSE(unproject(L, L.cx + L.fx * rdMax * (1 + 1e-9), L.cy));
}

// --- fisheye ----------------------------------------------------------------

TEST(LensFisheye, MatchesOpenCvFormulaAndHandWorkedValues) {
    Lens L = fisheyeLens();
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> xy(-3, 3), z(0.2, 100);
    for (int i = 0; i < 2000; ++i) {
        const double Z = z(rng);
        const Vec3d P{xy(rng) * Z, xy(rng) * Z, Z};
        const auto px = project(L, P);
        ASSERT_TRUE(px);
        const auto cv = opencvFisheye(L, P);
        EXPECT_NEAR(px->u, cv[0], kPixelTolerance);
        EXPECT_NEAR(px->v, cv[1], kPixelTolerance);
    }
    // By hand, fx = 300, fy = 310, cx = 320, cy = 240, k = (0.1, -0.02,
    // 0.003, -0.0004):
    //  (1, 0, 1): a = 1, b = 0, r = 1, theta = pi/4 = 0.785398, theta^2 =
    //    0.616850; theta_d = 0.785398 (1 + 0.0616850 - 0.0076101 + 0.0007041
    //    - 0.0000579) = 0.785398 x 1.0547211 = 0.828376;
    //    u = 320 + 300 x 0.828376 = 568.513, v = 240.
    //  (0, -2, 1): r = 2, theta = atan 2 = 1.107149, theta^2 = 1.225778;
    //    theta_d = 1.107149 (1 + 0.1225778 - 0.0300508 + 0.0055252 -
    //    0.0007216) = 1.107149 x 1.0971306 = 1.214708;
    //    u = 320, v = 240 + 310 x (1.214708 / 2) x (-2) = -136.559.
    //  (3, 4, 10): a = 0.3, b = 0.4, r = 0.5, theta = atan 0.5 = 0.463648,
    //    theta^2 = 0.214969; theta_d = 0.463648 (1 + 0.0214969 - 0.0009242
    //    + 0.0000298 - 0.0000009) = 0.463648 x 1.0206016 = 0.473200;
    //    u = 320 + 300 x 0.946400 x 0.3 = 405.176,
    //    v = 240 + 310 x 0.946400 x 0.4 = 357.354.
    L.fx = 300;
    L.fy = 310;
    L.cx = 320;
    L.cy = 240;
    L.k1 = 0.1;
    L.k2 = -0.02;
    L.k3 = 0.003;
    L.k4 = -0.0004;
    validateLens(L);
    const std::array<std::pair<Vec3d, std::array<double, 2>>, 3> byHand = {{
        {{1, 0, 1}, {568.513, 240.0}},
        {{0, -2, 1}, {320.0, -136.559}},
        {{3, 4, 10}, {405.176, 357.354}},
    }};
    for (const auto& [P, want] : byHand) {
        const auto px = project(L, P);
        ASSERT_TRUE(px);
        EXPECT_NEAR(px->u, want[0], 1e-3);
        EXPECT_NEAR(px->v, want[1], 1e-3);
    }
}

TEST(LensFisheye, FieldEndsWhereThetaDStopsGrowing) {
    // theta_d = theta (1 - 0.1 theta^2): d theta_d / d theta = 1 - 0.3 theta^2.
    Lens L = fisheyeLens();
    L.k1 = -0.1;
    L.k2 = L.k3 = L.k4 = 0;
    validateLens(L);
    const double thetaMax = std::sqrt(1 / 0.3);
    EXPECT_NEAR(maxFieldAngle(L), thetaMax, 1e-12);
    EXPECT_TRUE(project(L, direction(thetaMax - 1e-9, 1.1)));
    EXPECT_FALSE(project(L, direction(thetaMax + 1e-9, 1.1)));
    // Without terms the model is equidistant to the back of the lens.
    L.k1 = 0;
    validateLens(L);
    EXPECT_DOUBLE_EQ(maxFieldAngle(L), kPi);
    EXPECT_FALSE(project(L, {0, 0, -1}));
    const auto behind = project(L, direction(170 * kPi / 180, 0.5));
    ASSERT_TRUE(behind);
    EXPECT_NEAR(std::hypot((behind->u - L.cx) / L.fx, (behind->v - L.cy) / L.fy), 170 * kPi / 180, 1e-12);
}

// --- omnidirectional (OCamCalib) ---------------------------------------------

TEST(LensOmnidirectional, UnprojectIsOcamCalibCam2World) {
    const Lens L = omniLens();
    double worst = 0;
    for (int v = 0; v < L.height; v += 7)
        for (int u = 0; u < L.width; u += 7) {
            const auto ray = unproject(L, u, v);
            ASSERT_TRUE(ray);
            const Vec3d want = fromOcam(cam2world(L, v, u));  // point2D = [row, col]
            worst = std::max(worst, angleBetween(*ray, want));
        }
    EXPECT_LE(worst, 1e-14);
}

TEST(LensOmnidirectional, ProjectIsOcamCalibWorld2Cam) {
    const Lens L = omniLens();
    const double rhoMax = L.limits.inner;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> unit(0, 1);
    double worstExact = 0, worstInvpol = 0, invpolError = 0;
    for (int i = 0; i < 4000; ++i) {
        const Vec3d P = direction(maxFieldAngle(L) * std::sqrt(unit(rng)) * 0.999, 2 * kPi * unit(rng));
        const Vec3d scaled{P[0] * 37, P[1] * 37, P[2] * 37};
        const auto px = project(L, scaled);
        ASSERT_TRUE(px);
        const Vec3d M = toOcam(scaled);
        const double thetaOcam = std::atan(M[2] / std::hypot(M[0], M[1]));
        const auto exact = world2cam(L, M, [&](double t) { return rhoExact(L, t, rhoMax); });
        const auto fast = world2cam(L, M, [&](double t) { return rhoByInvpol(L, t); });
        worstExact = std::max(worstExact, std::hypot(px->u - exact[1], px->v - exact[0]));
        worstInvpol = std::max(worstInvpol, std::hypot(px->u - fast[1], px->v - fast[0]));
        // How far OCamCalib's own world2cam is from the exact inverse here.
        const double err = std::abs(rhoByInvpol(L, thetaOcam) - rhoExact(L, thetaOcam, rhoMax));
        invpolError = std::max(invpolError, err * std::sqrt(L.c * L.c + L.d * L.d + L.e * L.e + 1));  // |A|_F
    }
    EXPECT_LE(worstExact, kPixelTolerance);
    // world2cam with the file's invpol differs by invpol's fit error only.
    EXPECT_LE(worstInvpol, invpolError + kPixelTolerance);
    EXPECT_LT(invpolError, 1.0);
    RecordProperty("worst_vs_exact_world2cam_px", fmt::format("{:.3g}", worstExact));
    RecordProperty("worst_vs_invpol_world2cam_px", fmt::format("{:.3g}", worstInvpol));
    RecordProperty("invpol_fit_error_px", fmt::format("{:.3g}", invpolError));
}

TEST(LensOmnidirectional, CentreIsRowThenColumnAndSceneIsAtNegativeZ) {
    // With the affine at identity: the optical axis lands on (u, v) = (yc,
    // xc); a point to the right (+x) moves along the row, one below (+y)
    // along the column; OCamCalib's pol(0) < 0 is the scene's side.
    Lens L = omniLens();
    L.c = 1;
    L.d = L.e = 0;
    validateLens(L);
    const auto axis = project(L, {0, 0, 5});
    ASSERT_TRUE(axis);
    EXPECT_EQ(axis->u, L.yc);
    EXPECT_EQ(axis->v, L.xc);
    const auto right = project(L, {1, 0, 5});
    ASSERT_TRUE(right);
    EXPECT_GT(right->u, L.yc + 100);
    EXPECT_NEAR(right->v, L.xc, 1e-9);
    const auto down = project(L, {0, 1, 5});
    ASSERT_TRUE(down);
    EXPECT_NEAR(down->u, L.yc, 1e-9);
    EXPECT_GT(down->v, L.xc + 100);
    const auto centreRay = unproject(L, L.yc, L.xc);
    ASSERT_TRUE(centreRay);
    EXPECT_NEAR((*centreRay)[2], 1, 1e-15);
    // OCamCalib's own ray of the centre pixel is (0, 0, -1).
    EXPECT_NEAR(cam2world(L, L.xc, L.yc)[2], -1, 1e-15);
    EXPECT_FALSE(project(L, {0, 0, -5}));
}

TEST(LensOmnidirectional, FieldEndsAtFoldOrJustPastTheCorners) {
    // pol = a0 + a4 rho^4 with a4 < 0: the ray's angle grows while rho pol' -
    // pol = -a0 + 3 a4 rho^4 > 0, up to rho^4 = a0 / (3 a4) = 1e11.
    Lens L = omniLens();
    L.pol = {-300, 0, 0, 0, -1e-9};
    L.invpol.clear();
    validateLens(L);
    const double rhoFold = std::pow(1e11, 0.25);
    const double thetaFold = std::atan2(rhoFold, 300 + 1e-9 * std::pow(rhoFold, 4));
    EXPECT_NEAR(maxFieldAngle(L), thetaFold, 1e-12);
    EXPECT_TRUE(project(L, direction(thetaFold - 1e-9, 0.7)));
    EXPECT_FALSE(project(L, direction(thetaFold + 1e-9, 0.7)));
    const RoundTrip t = roundTrips(L, 0.99, true);
    EXPECT_GT(t.pixelsWithoutRay, 0);
    EXPECT_LE(t.worstPixel, kPixelTolerance);
    EXPECT_LE(t.worstRay, kAngleTolerance);

    // Without a fold: one pixel past the farthest corner.
    const Lens M = omniLens();
    const double det = M.c - M.d * M.e;
    double farthest = 0;
    for (const double u : {-0.5, M.width - 0.5})
        for (const double v : {-0.5, M.height - 0.5}) {
            const double row = v - M.xc, col = u - M.yc;
            farthest = std::max(farthest, std::hypot((row - M.d * col) / det, (-M.e * row + M.c * col) / det));
        }
    const double rhoMax = farthest + 1;
    EXPECT_NEAR(maxFieldAngle(M), std::atan2(rhoMax, -sumOfPowers(M.pol, rhoMax)), 1e-12);
    EXPECT_FALSE(project(M, direction(maxFieldAngle(M) + 1e-9, 0.2)));
}

// --- the preset -------------------------------------------------------------

TEST(LensPreset, DiagonalFieldOfViewReachesTheCornerEdges) {
    const Lens L = equidistantFisheye(640, 480, 140);
    EXPECT_EQ(L.model, LensModel::Fisheye);
    EXPECT_EQ(L.fx, L.fy);
    EXPECT_EQ(L.k1, 0);
    EXPECT_EQ(L.k4, 0);
    EXPECT_DOUBLE_EQ(L.cx, 319.5);
    EXPECT_DOUBLE_EQ(L.cy, 239.5);
    for (const auto& [u, v] : {std::pair{-0.5, -0.5}, {639.5, -0.5}, {-0.5, 479.5}, {639.5, 479.5}}) {
        const auto ray = unproject(L, u, v);
        ASSERT_TRUE(ray);
        EXPECT_NEAR(std::acos((*ray)[2]), 70 * kPi / 180, 1e-12);
    }
    // Equidistant: the angle grows linearly with the distance from the centre.
    for (const double du : {1.0, 50.0, 200.0, 320.0}) {
        const auto ray = unproject(L, L.cx + du, L.cy);
        ASSERT_TRUE(ray);
        EXPECT_NEAR(angleBetween(*ray, {0, 0, 1}), du / L.fx, 1e-12);
    }
    const auto axis = unproject(L, L.cx, L.cy);
    ASSERT_TRUE(axis);
    EXPECT_EQ((*axis)[2], 1);
    EXPECT_DOUBLE_EQ(maxFieldAngle(L), kPi);
}

TEST(LensPreset, HorizontalFieldOfViewReachesTheSideEdges) {
    const Lens L = equidistantFisheye(1350, 1080, 120, FieldOfViewSpan::Horizontal);
    for (const double u : {-0.5, 1349.5}) {
        const auto ray = unproject(L, u, L.cy);
        ASSERT_TRUE(ray);
        EXPECT_NEAR(std::acos((*ray)[2]), 60 * kPi / 180, 1e-12);
    }
    EXPECT_THROW(equidistantFisheye(640, 480, 0), InputError);
    EXPECT_THROW(equidistantFisheye(640, 480, 360), InputError);
    EXPECT_THROW(equidistantFisheye(0, 480, 120), InputError);
}

// --- validation and JSON ----------------------------------------------------

TEST(LensJson, EveryModelRoundTripsThroughJson) {
    TempDir dir;
    for (const Lens& L : {pinholeLens(), fisheyeLens(), omniLens(), equidistantFisheye(320, 240, 150)}) {
        SCOPED_TRACE(lensModelName(L.model));
        const fs::path path = dir / "lens.json";
        std::ofstream(path) << lensJson(L).dump(2);
        const Lens back = readLens(path);
        EXPECT_EQ(lensJson(back), lensJson(L));
        EXPECT_EQ(back.limits.thetaMax, L.limits.thetaMax);
        for (const double t : {0.1, 0.5, 0.9}) {
            const Vec3d d = direction(t * maxFieldAngle(L), 0.4);
            const auto a = project(L, d), b = project(back, d);
            ASSERT_TRUE(a && b);
            EXPECT_EQ(a->u, b->u);
            EXPECT_EQ(a->v, b->v);
        }
    }
}

std::string refusal(const json& j, const std::string& where = "") {
    try {
        lensFromJson(j, "lens.json", where);
    } catch (const InputError& e) {
        return describe(e);
    }
    return "(accepted)";
}

TEST(LensJson, BadFieldsAreRefusedByName) {
    const json pinhole = lensJson(pinholeLens()), fisheye = lensJson(fisheyeLens()), omni = lensJson(omniLens());
    auto with = [](json j, const std::string& key, const json& value) {
        j[key] = value;
        return j;
    };
    auto without = [](json j, const std::string& key) {
        j.erase(key);
        return j;
    };
    std::vector<double> reversed = omniLens().invpol;
    std::reverse(reversed.begin(), reversed.end());
    const std::vector<std::pair<json, std::string>> cases = {
        {json::array(), "lens in lens.json: must be a JSON object"},
        {without(pinhole, "model"), "field 'model' in lens.json: is missing"},
        {with(pinhole, "model", "kannala"), "field 'model' in lens.json: 'kannala' is not a lens model"},
        {with(pinhole, "model", 3), "field 'model' in lens.json: must be a string"},
        {with(pinhole, "fx", -500), "field 'fx' in lens.json: focal lengths must be positive"},
        {with(pinhole, "fy", "510"), "field 'fy' in lens.json: must be a number"},
        {without(pinhole, "cy"), "field 'cy' in lens.json: is missing"},
        {with(pinhole, "k3", 0.01), "field 'k3' in lens.json: is not a parameter of the pinhole model"},
        {with(pinhole, "width", 0), "field 'width' in lens.json: 0 is out of range [1, 65536]"},
        {with(fisheye, "height", 479.5), "field 'height' in lens.json: must be a whole number"},
        {with(fisheye, "pol", json::array({-1})), "field 'pol' in lens.json: is not a parameter of the fisheye"},
        {with(omni, "pol", json::array()), "field 'pol' in lens.json: must have 1 to 64 coefficients"},
        {with(omni, "pol", json::array({"a"})), "field 'pol[0]' in lens.json: must be a finite number"},
        {with(omni, "pol", json::array({250, 0, 0.001})), "field 'pol' in lens.json: a0 = 250 must be negative"},
        {with(omni, "invpol", reversed), "field 'invpol' in lens.json: is "},
        {without(omni, "xc"), "field 'xc' in lens.json: is missing"},
        {with(with(omni, "d", 2), "e", 1), "field 'c' in lens.json: the affine [c d; e 1] has determinant"},
        {with(omni, "fx", 300), "field 'fx' in lens.json: is not a parameter of the omnidirectional model"},
    };
    for (const auto& [j, want] : cases) {
        const std::string got = refusal(j);
        EXPECT_NE(got.find(want), std::string::npos) << "got: " << got << "\nwant: " << want;
    }
    EXPECT_NE(refusal(with(pinhole, "fx", 0), "camera.lens.").find("field 'camera.lens.fx' in lens.json"),
              std::string::npos);
}

TEST(LensJson, MalformedJsonIsRefusedWithItsPlace) {
    TempDir dir;
    const fs::path path = dir / "lens.json";
    std::ofstream(path) << "{\"model\": \"pinhole\",\n \"width\": 640,,}";
    try {
        readLens(path);
        FAIL() << "accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), 2);
        EXPECT_NE(describe(e).find(path.string()), std::string::npos);
    }
}

TEST(LensJson, UnvalidatedLensIsAnInternalError) {
    Lens L;
    L.model = LensModel::Fisheye;
    L.width = 10;
    L.height = 10;
    L.fx = L.fy = 5;
    EXPECT_THROW(project(L, {0, 0, 1}), InternalError);
    EXPECT_THROW(unproject(L, 1, 1), InternalError);
}

// --- OCamCalib's calib_results.txt -------------------------------------------

// The layout OCamCalib's export writes: comment lines, blank lines, five
// lines of numbers.
std::string calibText(const std::string& pol, const std::string& invpol, const std::string& centre,
                      const std::string& affine, const std::string& size) {
    return "#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). These are used by "
           "cam2world\n\n" +
           pol +
           "\n\n#polynomial coefficients for the inverse mapping function (ocam_model.invpol in MATLAB). These are "
           "used by world2cam\n\n" +
           invpol + "\n\n#center: \"row\" and \"column\", starting from 0 (C convention)\n\n" + centre +
           "\n\n#affine parameters \"c\", \"d\", \"e\"\n\n" + affine + "\n\n#image size: \"height\" and \"width\"\n\n" +
           size + "\n\n";
}

// f = 1400 px: the equidistant series of omniLens() to rho^4, as the toolbox prints it.
const std::string kPol = "5 -1.400000e+03 0.000000e+00 2.380952e-04 0.000000e+00 8.098477e-12 ";
const std::string kInvpol = "2 2199.114858 1400.000000 ";

TEST(LensOcamCalib, ReadsTheToolboxLayout) {
    TempDir dir;
    const fs::path path = dir / "calib_results.txt";
    std::ofstream(path) << calibText(kPol, kInvpol, "531.700000 688.200000", "1.030000 0.020000 -0.015000",
                                     "1080 1350");
    const Lens L = readOcamCalib(path);
    EXPECT_EQ(L.model, LensModel::Omnidirectional);
    EXPECT_EQ(L.pol, (std::vector<double>{-1400, 0, 2.380952e-04, 0, 8.098477e-12}));
    EXPECT_EQ(L.invpol, (std::vector<double>{2199.114858, 1400}));
    EXPECT_EQ(L.xc, 531.7);  // the row
    EXPECT_EQ(L.yc, 688.2);  // the column
    EXPECT_EQ(L.c, 1.03);
    EXPECT_EQ(L.d, 0.02);
    EXPECT_EQ(L.e, -0.015);
    EXPECT_EQ(L.height, 1080);
    EXPECT_EQ(L.width, 1350);
    // Windows line ends read the same.
    std::string crlf;
    for (const char ch : calibText(kPol, kInvpol, "531.7 688.2", "1.03 0.02 -0.015", "1080 1350")) {
        if (ch == '\n') crlf += '\r';
        crlf += ch;
    }
    EXPECT_EQ(lensJson(parseOcamCalib(crlf, "crlf.txt")), lensJson(L));
}

TEST(LensOcamCalib, MalformedFilesAreRefusedAtTheirLine) {
    // Data lines in calibText: pol 3, invpol 7, centre 11, affine 15, size 19.
    struct Case {
        std::string text;
        int line;
        std::string want;
    };
    const std::vector<Case> cases = {
        {calibText("5 -1400 0 0.0002 0", kInvpol, "531 688", "1 0 0", "1080 1350"), 3,
         "pol: has 4 coefficients after the count 5"},
        {calibText("2.5 -1400 0", kInvpol, "531 688", "1 0 0", "1080 1350"), 3, "pol: the line starts with the count"},
        {calibText(kPol, "2 2199.1 14OO", "531 688", "1 0 0", "1080 1350"), 7, "invpol: '14OO' is not a finite number"},
        {calibText(kPol, kInvpol, "531", "1 0 0", "1080 1350"), 11, "centre: must be two numbers"},
        {calibText(kPol, kInvpol, "531 688", "1 0", "1080 1350"), 15, "affine: must be three numbers"},
        {calibText(kPol, kInvpol, "531 688", "1 0 0", "1080"), 19, "image size: must be two numbers"},
        {calibText(kPol, kInvpol, "531 688", "1 0 0", "0 1350"), 19, "image size: the height must be a whole number"},
        {calibText("3 700 0 0.001", kInvpol, "531 688", "1 0 0", "1080 1350"), 3, "pol: a0 = 700 must be negative"},
        {calibText(kPol, "2 1400.000000 2199.114858", "531 688", "1 0 0", "1080 1350"), 7, "invpol: is "},
        {calibText(kPol, kInvpol, "531 688", "1 2 1", "1080 1350"), 15, "affine: the affine [c d; e 1]"},
        {calibText(kPol, kInvpol, "531 688", "1 0 0", "1080 1350") + "7\n", 21, "unexpected numbers"},
        {"# nothing\n" + kPol + "\n" + kInvpol + "\n531 688\n", 0, "has 3 lines of numbers"},
    };
    for (const auto& c : cases) {
        try {
            parseOcamCalib(c.text, "calib_results.txt");
            ADD_FAILURE() << "accepted: " << c.want;
        } catch (const InputError& e) {
            const std::string got = describe(e);
            EXPECT_NE(got.find(c.want), std::string::npos) << "got: " << got << "\nwant: " << c.want;
            EXPECT_EQ(e.line(), c.line) << got;
            EXPECT_NE(got.find("calib_results.txt"), std::string::npos) << got;
        }
    }
}

}  // namespace
}  // namespace mucosa::dataset
