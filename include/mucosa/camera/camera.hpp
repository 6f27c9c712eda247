#pragma once
// The endoscope: a perspective camera with the bronchoscope's wide field of
// view (the paper's Olympus BF: 120 degrees) and one point light at its tip
// (DESIGN.md, "Endoscope"), plus camera paths: a list of poses, or a
// fly-through along a centerline with smooth orientation.
#include <array>
#include <vector>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::camera {

using Vec3 = mesh::Vec3;
using Mat4 = std::array<float, 16>;  // column-major (OpenGL)

struct Pose {
    Vec3 position{0, 0, 0};  // mm
    Vec3 forward{0, 0, -1};  // viewing direction (normalised on use)
    Vec3 up{0, 1, 0};        // roughly up; made orthogonal to forward on use
};

struct Lens {
    float fovDeg = 120.0f;  // across the larger image dimension
    float nearMm = 0.5f;
    float farMm = 400.0f;
};

// Light at the tip, offset in the camera's frame (x right, y up, z forward), mm.
struct TipLight {
    Vec3 offset{0, 0, 0};
};

// Throws InputError naming the field ("camera.fov_deg", ...).
void validate(const Lens& lens);

Mat4 viewMatrix(const Pose& pose);
Mat4 projectionMatrix(const Lens& lens, int width, int height);
Vec3 lightPosition(const Pose& pose, const TipLight& light);
// Pose looking from `eye` at `target`.
Pose lookAt(const Vec3& eye, const Vec3& target, const Vec3& up = {0, 1, 0});

// Frames along a list of key poses: positions interpolated by Catmull-Rom,
// orientations by normalised lerp of forward and up. frames >= 1; one key pose
// gives it `frames` times.
std::vector<Pose> interpolatePoses(const std::vector<Pose>& keys, int frames);

struct FlyThrough {
    int frames = 120;
    // mm between consecutive frames; 0 = spread the frames over the whole path.
    float speedMm = 0.0f;
    float startMm = 0.0f;      // arc length where the flight starts
    float stopMm = 0.0f;       // arc length before the end where it stops (frames spread up to there)
    float lookAheadMm = 8.0f;  // the camera looks at the centerline this far ahead (smooth turns)
    Vec3 up{0, 1, 0};          // initial up; then transported without twist
};

// Poses along a polyline (a centerline, mm): position on the line, looking
// ahead along it, up vector parallel-transported (rotation-minimising: no
// sudden rolls). Throws InputError if the path has fewer than two distinct points.
std::vector<Pose> flyThrough(const std::vector<Vec3>& centerline, const FlyThrough& options);

// Length of a polyline (mm).
float pathLength(const std::vector<Vec3>& polyline);

}  // namespace mucosa::camera
