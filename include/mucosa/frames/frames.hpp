#pragma once
// Registered endoscope frames: images with pinhole
// intrinsics (OpenCV axes: x right, y down, z forward; pixel centres at
// integer coordinates), optional radial distortion k1, k2, and a row-major 4x4
// camera_to_world in the mesh's units. The light is a point at `lightOffset`
// in camera coordinates (0 = at the camera).
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mucosa::frames {

using Mat4 = std::array<std::array<double, 4>, 4>;
using Vec3d = std::array<double, 3>;

struct Intrinsics {
    int width = 0, height = 0;
    double fx = 0, fy = 0, cx = 0, cy = 0;
    double k1 = 0, k2 = 0;  // radial distortion (Brown-Conrady, OpenCV's k1, k2)
};

struct Frame {
    std::filesystem::path image;  // resolved against the frames file's folder
    Intrinsics K;
    Mat4 cameraToWorld{};
    bool flagged = false;  // registration.converged is false (`mucosa register` could not register it)
    // The linear gain the camera applied to this frame's signal (the file's
    // "exposure": 2^EV; mucosa render's datasets record it per frame), which
    // the frame's linearised values are divided by. 0: not recorded (a real
    // scope's frames): one unknown gain for all frames, which the albedo takes.
    double exposure = 0;
};

// How a frame's pixel values (0..1) go back to the sensor's linear signal:
// a power law, linear = value^gamma (the file's "gamma"), or the inverse of a
// standard camera response (the file's "tone_curve": "linear", "bt709" or
// "srgb": the curves of shaders/camera.glsl; video bronchoscopes put out
// BT.709).
// A frame's natural vignetting, cos^k of the field angle (the file's
// "vignetting": k), is divided out too. A video processor's colour
// enhancement (the file's "saturation": g, camera.saturation; shaders/
// camera.glsl enhanceColour: v' = luma + g (v - luma) on the tone-curved
// values, Rec. 709 luma, which it leaves unchanged) is undone first:
// v = luma' + (v' - luma') / g, exact where it did not clip (g = 0, a grey
// frame, is left as it is). With a tone curve, a video camera's highlight
// knee (the file's "knee": k, camera.knee) is undone after the enhancement
// and before the curve.
struct Response {
    double gamma = 1.0;
    int toneCurve = -1;     // -1: the power law; else camera.tone_curve's choice (0 linear, 1 BT.709, 2 sRGB)
    double vignetting = 0;  // k of cos^k(field angle); 0 = none
    double colourGain = 1;  // "saturation": colour gain g about the luma after the tone curve; 1 = none
    double knee = 1;        // "knee": the highlight knee's output level (with a tone curve); 1 = none
    // "flare": the veiling glare the frames carry (camera.flare: that share of
    // the field's mean radiance on every pixel). Recorded, not undone: it
    // depends on each view, and `mucosa fit` warns that it biases the fit.
    double flare = 0;
    Response() = default;
    Response(double powerLaw) : gamma(powerLaw) {}  // NOLINT(google-explicit-constructor): a number is a power law
    double linear(double value) const noexcept;
    double encode(double linear) const noexcept;  // the inverse of linear(), for linear in [0, 1]
    // The colour enhancement on an RGB pixel's values (0..1, after the tone
    // curve), as the camera applies it (clamped to [0, 1]), and its inverse
    // (unclamped: a value the enhancement clipped does not come back).
    std::array<double, 3> enhance(const std::array<double, 3>& rgb) const noexcept;
    std::array<double, 3> unenhance(const std::array<double, 3>& rgb) const noexcept;
    // cos^vignetting of the field angle at pixel (x, y) (shaders/camera.glsl;
    // pixel centres at integer coordinates): 1 without vignetting.
    double vignette(const Intrinsics& K, double x, double y) const noexcept;
};

// "linear", "bt709", "srgb" for 0, 1, 2 (camera.tone_curve's choices); "" otherwise.
const char* toneCurveName(int curve) noexcept;

struct FrameSet {
    std::string units = "mm";
    Response response;
    Vec3d lightOffset{0, 0, 0};
    // The frames were rendered with auto-exposure (the file's "auto_exposure":
    // true; mucosa render's manifest of a photographic mode with
    // camera.auto_exposure on): each frame has an exposure of its own, which
    // the shading cannot be told from, so fitFrames refuses them unless every
    // frame's exposure is recorded (Frame::exposure).
    bool autoExposure = false;
    std::vector<Frame> frames;
};

// Throws InputError naming the file and the field (e.g. "frames[2].intrinsics.fx").
// A frames file whose top-level "lens" is not a pinhole (mucosa render
// --lens: a fisheye or omnidirectional dataset) is refused unless anyLens:
// its intrinsics are then the lens's fx, fy, cx, cy only, and the caller
// reads the lens itself (dataset::lensFromJson).
FrameSet readFrames(const std::filesystem::path& path, bool anyLens = false);
// `extra`: top-level keys written after the frames file's own (a dataset's
// "outputs" and "dataset" blocks); readFrames ignores them.
void writeFrames(const std::filesystem::path& path, const FrameSet& set,
                 const nlohmann::json& extra = nlohmann::json::object());

// A camera file (`mucosa register --camera`): the keys a frames file uses,
// {"intrinsics": {width, height, fx, fy, cx, cy[, k1, k2]}, "gamma" or
// "tone_curve", "vignetting", "saturation", "light": {"offset", "spread",
// "source_radius_mm", "ambient"}, "units": "mm"}.
// The lamp's profile beyond its position (the renderer's lamp, docs/theory.md
// "The endoscope's lamp"): irradiance exp(-spread (1 - cos theta)) /
// (d^2 + radiusMm^2), theta from the optical axis. Both 0: a point source,
// the paper's model.
struct LampProfile {
    double spread = 0;
    double radiusMm = 0;
    // Light the airway's walls scatter back onto each other: a constant
    // irradiance, as a fraction of the lamp's on-axis irradiance at 10 mm
    // (the renderer's material.ambient). It flattens the far lumen's shading,
    // which the pq estimator reads as shape unless the model has it too.
    double ambient = 0;
};

struct CameraModel {
    Intrinsics K;
    Response response;
    Vec3d lightOffset{0, 0, 0};
    LampProfile lamp;  // "light": {"spread", "source_radius_mm", "ambient"}
};
CameraModel readCamera(const std::filesystem::path& path);

// A pose file: {"position", "look_at", "up"} (world, mm) or a row-major 4x4
// "camera_to_world" (OpenCV axes). Returns camera_to_world.
Mat4 readPose(const std::filesystem::path& path);

// A camera_to_world from a position, a look-at point and an up direction
// (OpenCV axes: z toward look_at, y down, so `up` maps to -y). Throws
// InputError when look_at = position or up is parallel to the view.
Mat4 lookAtPose(const Vec3d& position, const Vec3d& lookAt, const Vec3d& up);

// Camera centre in world coordinates and world -> camera transform.
Vec3d cameraCentre(const Mat4& cameraToWorld) noexcept;
Mat4 invertRigid(const Mat4& m) noexcept;
// How far a camera_to_world's rotation is from a rotation: the largest entry
// of |R^T R - I|, and det R. readFrames accepts orthonormality up to
// kRigidTolerance, det > 0 and a last row 0 0 0 1.
struct Rigidity {
    double orthonormality = 0;
    double determinant = 1;
};
Rigidity rigidity(const Mat4& m) noexcept;
inline constexpr double kRigidTolerance = 1e-3;
Vec3d transformPoint(const Mat4& m, const Vec3d& p) noexcept;
Vec3d transformDirection(const Mat4& m, const Vec3d& d) noexcept;

// Normalised image coordinates (x/z, y/z) -> distorted pixel, and back.
std::array<double, 2> project(const Intrinsics& K, double xn, double yn) noexcept;
std::array<double, 2> unproject(const Intrinsics& K, double px, double py) noexcept;

// The GL camera of a registered frame: OpenCV intrinsics (pixel centres at
// integer coordinates) and camera_to_world -> column-major view and projection
// matrices for OpenGL, with the first image row at the top. Distortion is not
// modelled by the rasteriser (frames with k1/k2 should be undistorted first).
std::array<float, 16> glViewMatrix(const Mat4& cameraToWorld);
std::array<float, 16> glProjectionMatrix(const Intrinsics& K, double nearMm, double farMm);

}  // namespace mucosa::frames
