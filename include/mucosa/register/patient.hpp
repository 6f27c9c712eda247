#pragma once
// A synthetic patient (docs/theory.md, "A synthetic patient"): the built-in
// phantom as the patient's CT airway, and a bronchoscopy of it rendered at
// known poses, so that the patient pipeline (register -> fit -> categories)
// can be run from raw data and scored against the truth it never sees.
//
// The scope enters the lower trachea, passes the carina into the right main
// bronchus and on into its lobar bronchus, like a bronchoscopist: off the
// centre and turning to the walls, rolling the scope by hand, pausing and
// pulling back now and then. The video goes through the endoscope's camera
// (auto-exposure, the exposure jittered frame to frame, Poisson-Gaussian
// noise, vignetting, BT.709, the circular mask) into 8-bit PNGs.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mucosa/frames/frames.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/shading/brdf.hpp>
#include <mucosa/shading/params.hpp>

namespace mucosa::registration {

// How the video is shaded.
enum class PatientLook {
    // The photographic `noise` mode: the lamp's own inverse-square fall-off
    // and angular spread, wrap, the mucus sheen, the method's highlights,
    // through the GL camera (a bronchoscopy as the scope shows it).
    Lamp,
    // The study's category 4: the albedo texture, rho(gamma) delta(r) with the
    // truth's brdf (whose cubic delta(r) is the closest a cubic comes to the
    // lamp's fall-off, see theory.md), the method's noise-shaped highlights.
    Category4,
};

struct PatientOptions {
    int frames = 300;
    int size = 320;         // square frames, pixels
    double fovDeg = 110.0;  // across the frame
    PatientLook look = PatientLook::Lamp;
    double exposureJitter = 0.3;               // each frame's exposure x a factor uniform in [1 - j, 1 + j]
    double startMm = 60.0;                     // where the path starts, along the trachea's centerline (mm)
    double stopMm = 12.0;                      // how far before the lobar bronchus's end it stops (mm)
    double speedMm = 0.6;                      // forward, per frame (15 mm/s at 25 frames/s)
    double rollDeg = 25.0;                     // amplitude of the hand's roll of the scope
    bool pauses = true;                        // the scope stops, pulls back and goes on, now and then
    frames::Vec3d lightOffset{0.0, 1.2, 0.0};  // the lamp in camera coordinates (OpenCV axes, mm)
    std::uint64_t seed = 1;
    // Empty: the phantom. Else a patient's CT airway (any format mesh::load
    // reads, mm, normals facing the lumen): centerline UVs are computed on it,
    // and the path follows the longest branch of its computed centerline.
    std::filesystem::path meshFile;
    // Registry parameters set on the video's scene after the look's own
    // (e.g. light.spread 0: a lamp without angular fall-off).
    std::vector<std::pair<shading::Param, float>> params;
    int threads = 0;
};

struct SyntheticPatient {
    mesh::Mesh mesh;             // the "CT" airway (the phantom or meshFile; centerline UVs, normals into the lumen)
    frames::CameraModel camera;  // what the scope's calibration says (intrinsics, response, lamp offset)
    std::vector<frames::Mat4> poses;      // the truth: each frame's camera_to_world (OpenCV axes, mm)
    std::vector<double> exposureFactors;  // the per-frame jitter on top of auto-exposure
    shading::BrdfParams brdf;             // the truth's rho and delta (Category4)
    image::Image8 texture;                // the truth's albedo (sRGB, tileable; the mesh's UVs wrap it)
    std::string branch;                   // the bronchus the path ends in
    // A CT airway's path is cut where it leaves the lumen (checked every mm):
    // the arc length (mm from the centerline's start) where the scope stops; 0 = not cut.
    double pathStopMm = 0;
    PatientOptions options;
};

// Builds the phantom and the path (no rendering). Throws InputError naming
// the option for options out of range.
SyntheticPatient makeSyntheticPatient(const PatientOptions& options);

// Renders the video frame by frame (one GL context; auto-exposure carries
// from frame to frame, so render them in order).
class PatientVideo {
public:
    explicit PatientVideo(const SyntheticPatient& patient);
    ~PatientVideo();
    PatientVideo(const PatientVideo&) = delete;
    PatientVideo& operator=(const PatientVideo&) = delete;
    image::Image8 frame(int index);  // RGB, display-referred 8-bit

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Writes what a clinical user would bring, and the truth beside it:
//   dir/airway.glb            the CT airway
//   dir/camera.json           intrinsics, tone curve, vignetting, lamp offset
//   dir/init.json             the first frame's pose as a user would set it
//                             (the truth moved by initErrorMm and initErrorDeg)
//   dir/video/frame_NNNN.png  the bronchoscopy
//   dir/truth/frames.json     the true poses (a frames file of the video)
//   dir/truth/brdf.json, dir/truth/texture.png
// Every frame is rendered afresh, in order (auto-exposure carries from frame
// to frame), each PNG written atomically; progress(done, total) after each.
struct PatientWriteOptions {
    double initErrorMm = 1.0, initErrorDeg = 2.0;
    std::function<void(int done, int total)> progress;
};
void writeSyntheticPatient(const SyntheticPatient& patient, const std::filesystem::path& dir,
                           const PatientWriteOptions& options = {});

// The truth's albedo at texture coordinates (u, v) (wrapping), linear RGB.
std::array<double, 3> truthAlbedo(const SyntheticPatient& patient, double u, double v);

}  // namespace mucosa::registration
