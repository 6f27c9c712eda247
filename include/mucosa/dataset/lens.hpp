#pragma once
// Endoscope lens models: the map between a ray in the camera's frame and a
// pixel, exact both ways, for rendering through a cube map (unproject every
// output pixel) and for per-pixel ground truth (project surface points).
// docs/datasets.md, "Lens models".
//
// Mucosa's conventions throughout: OpenCV camera axes (x right, y down, z
// forward, the direction of view) and pixel centres at integer coordinates
// (the top-left pixel's centre is (0, 0)), as frames::Intrinsics.
//
//  - Pinhole: fx, fy, cx, cy and Brown radial distortion k1, k2 on the
//    normalised coordinates (x/z, y/z): exactly frames::project and OpenCV's
//    cv::projectPoints with distortion (k1, k2, 0, 0).
//  - Fisheye: OpenCV's fisheye model (cv::fisheye, calib3d "Fisheye camera
//    model"), the Kannala-Brandt polynomial (Kannala & Brandt 2006, eq. 6):
//    theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8),
//    theta the angle from the optical axis; no skew.
//  - Omnidirectional: Scaramuzza's model as OCamCalib calibrates it
//    (Scaramuzza, Martinelli & Siegwart 2006) and ships it in
//    calib_results.txt; see Lens's fields for its conventions.
//
// A lens is plain data plus limits derived from it: validateLens() checks the
// parameters and derives the limits; every maker and reader here calls it, so
// call it again after editing a lens's parameters by hand.
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/image.hpp>

namespace mucosa::dataset {

using Vec3d = frames::Vec3d;

struct PixelPoint {
    double u = 0, v = 0;  // column (x, right) and row (y, down); pixel centres at integers
};

enum class LensModel { Pinhole, Fisheye, Omnidirectional };

// "pinhole", "fisheye", "omnidirectional".
const char* lensModelName(LensModel model) noexcept;

// Where a model stops being one-to-one, in each variable the model uses.
// Derived by validateLens(); project() and unproject() refuse what lies at or
// beyond it.
struct LensLimits {
    double thetaMax = 0;  // maxFieldAngle(), radians from the optical axis
    // The same limit in the model's own variables: the undistorted variable
    // (pinhole: tan theta; fisheye: theta; omnidirectional: rho) and the
    // distorted one (pinhole: r_d of the normalised coordinates; fisheye:
    // theta_d; omnidirectional: rho again). Infinite where there is none.
    double inner = 0;
    double outer = 0;
};

struct Lens {
    LensModel model = LensModel::Pinhole;
    int width = 0, height = 0;

    // Pinhole and Fisheye: focal lengths and principal point, pixels.
    double fx = 0, fy = 0, cx = 0, cy = 0;
    // Pinhole: Brown k1, k2 (k3 and k4 must be 0). Fisheye: Kannala-Brandt
    // k1..k4.
    double k1 = 0, k2 = 0, k3 = 0, k4 = 0;

    // Omnidirectional, in OCamCalib's own terms (ocam_functions.c, the C
    // interface shipped with the OCamCalib toolbox; calib_results.txt):
    //  - its camera frame has x along the image's ROWS (down), y along its
    //    COLUMNS (right), and the scene at NEGATIVE z: the ray of a pixel at
    //    (x', y') from the centre, once the affine part is undone, is
    //    (x', y', pol(rho)), rho = |(x', y')|, with pol(0) = a0 < 0. In
    //    Mucosa's axes that ray is (y', x', -pol(rho)): a proper rotation of
    //    OpenCV's frame, no mirror.
    //  - pol: a0, a1, a2, ... (constant first, as the file lists them); a1 is
    //    0 in OCamCalib's calibrations (the paper's f'(0) = 0), any value is
    //    accepted.
    //  - invpol: rho as a polynomial of OCamCalib's theta = atan(z / |(x, y)|)
    //    (-pi/2 on the optical axis), constant first: the toolbox's fitted
    //    approximation of pol's inverse (within 0.01 px, its findinvpoly.m).
    //    Mucosa inverts pol exactly (Newton) and uses invpol only as the
    //    starting point; it may be empty.
    //  - xc, yc: the centre as (ROW, COLUMN), 0-based ("C convention"), so
    //    in Mucosa's pixels u = yc, v = xc at the centre.
    //  - c, d, e: the affine map (row - xc, col - yc) = [c d; e 1] (x', y').
    std::vector<double> pol;
    std::vector<double> invpol;
    double xc = 0, yc = 0;
    double c = 1, d = 0, e = 0;

    LensLimits limits;  // derived: validateLens()
};

// Checks a lens's parameters and derives its limits: throws InputError
// naming the field (`where` + name, e.g. "camera.lens.fx") and `file`.
void validateLens(Lens& lens, const std::string& file = "", const std::string& where = "");

// The largest angle from the optical axis (radians) the model maps one to
// one, computed from the parameters:
//  - pinhole: pi/2, or less where Brown's r (1 + k1 r^2 + k2 r^4) stops
//    increasing with r;
//  - fisheye: pi, or less where theta_d stops increasing with theta (rays
//    beyond 90 degrees are the model's, continued past OpenCV's x/z);
//  - omnidirectional: the angle at the image's farthest corner (rho up to
//    one pixel beyond it: the calibration saw nothing farther out, and
//    OCamCalib's own inverse stops at half the diagonal), or less where the
//    ray's angle stops increasing with rho.
double maxFieldAngle(const Lens& lens);

// The pixel where a point (or direction) in the camera's frame is seen:
// nullopt behind the lens or at or beyond maxFieldAngle. Pixels outside the
// image are returned (the caller decides whether it wants them), except for
// the omnidirectional model, whose field ends just past the image's corners.
std::optional<PixelPoint> project(const Lens& lens, const Vec3d& cameraPoint);

// The unit ray (camera frame, OpenCV axes) seen at pixel (u, v): nullopt
// where no ray maps there (beyond the model's field). The exact inverse of
// project() up to the Newton tolerance below.
std::optional<Vec3d> unproject(const Lens& lens, double u, double v);

// Newton's method inverts the models' polynomials (pinhole r_d(r), fisheye
// theta_d(theta), the omnidirectional ray angle of rho) inside a bracket that
// ends at the model's limit, bisecting whenever a step would leave it or
// stall (Numerical Recipes' rtsafe): it stops when a step is below
// kLensTolerance x max(1, |x|) (a few ulps), or after kLensMaxIterations.
// Typically 2 to 7 iterations.
inline constexpr double kLensTolerance = 1e-15;
inline constexpr int kLensMaxIterations = 100;

// The pinhole of a frames file's intrinsics (fx, fy, cx, cy, k1, k2).
Lens fromIntrinsics(const frames::Intrinsics& K);

// A bronchoscope-like fisheye: Kannala-Brandt with k1..k4 = 0, i.e.
// equidistant (r = f theta, Kannala & Brandt 2006, eq. 3), fx = fy = f,
// centred (cx = (width - 1) / 2, cy = (height - 1) / 2), whose field of view
// `fieldOfViewDeg` (degrees, less than 360) spans the image's diagonal or
// its width: the outer edges of the corner (or leftmost and rightmost)
// pixels see rays at half that angle from the axis.
enum class FieldOfViewSpan { Diagonal, Horizontal };
Lens equidistantFisheye(int width, int height, double fieldOfViewDeg, FieldOfViewSpan span = FieldOfViewSpan::Diagonal);

// JSON: {"model": "pinhole", "width", "height", "fx", "fy", "cx", "cy"[,
// "k1", "k2"]}, {"model": "fisheye", ... [, "k1", "k2", "k3", "k4"]} or
// {"model": "omnidirectional", "width", "height", "pol": [a0, ...][,
// "invpol": [...]], "xc", "yc"[, "c", "d", "e"]} (xc the ROW). Unknown keys
// are refused. Throws InputError naming the field (`where` + name) and the
// file, one per bad field.
Lens lensFromJson(const nlohmann::json& j, const std::string& file = "", const std::string& where = "");
Lens readLens(const std::filesystem::path& path);
nlohmann::json lensJson(const Lens& lens);

// OCamCalib's calib_results.txt (the toolbox's export; its C reader
// get_ocam_model): '#' comment lines and blank lines, then five lines of
// numbers: the count of pol's coefficients and pol (constant first); the
// same for invpol; the centre "row column"; the affine "c d e"; the image
// size "height width". A malformed file is refused with one InputError at
// its line and column.
Lens readOcamCalib(const std::filesystem::path& path);

// A lens file of either kind: OCamCalib's calib_results.txt when the name
// does not end in .json, else readLens.
Lens readLensFile(const std::filesystem::path& path);

// Every pixel centre's ray (unproject), as a width x height x 3 image in the
// camera's frame (OpenCV axes); (0, 0, 0) where the lens sees nothing. What
// render::Renderer::setLensRays draws through.
image::ImageF rayImage(const Lens& lens);
Lens parseOcamCalib(std::string_view text, const std::string& file = "");

}  // namespace mucosa::dataset
