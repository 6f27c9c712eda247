#pragma once
// The endoscope: a perspective camera with the bronchoscope's wide field of
// view (the paper's Olympus BF: 120 degrees) and one point light at its tip
// (DESIGN.md, "Endoscope"), plus camera paths: a list of poses, or a
// fly-through along a centerline with smooth orientation.
#include <array>
#include <cstdint>
#include <vector>

#include <mucosa/mesh/centerline.hpp>
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
    // Like a bronchoscopist, who keeps the tip off the centre and turns it to
    // inspect the walls and the openings ahead. Both 0: on the centerline,
    // looking ahead (exactly the centred path).
    float wander = 0.0f;           // off-centre offset, a fraction (0..0.9) of the local lumen radius
    float lookAroundDeg = 0.0f;    // how far the view turns from ahead (degrees, 0..60)
    float wallClearanceMm = 1.5f;  // the offset keeps the eye this far inside the (nominal) wall
    float wanderPeriodMm = 40.0f;  // shortest period of the wandering along the path (mm): its smoothness
    std::uint64_t seed = 1;        // the wandering's pattern (deterministic)
};

// Poses along a polyline (a centerline, mm): looking ahead along it, up vector
// parallel-transported (rotation-minimising: no sudden rolls). With wander > 0
// and `radii` (the lumen radius at each point, mm; the centerline JSON's
// "radii"), the eye moves off the line by a smooth seeded offset of at most
// wander x the smallest radius within 6 mm along the path, and never closer
// than wallClearanceMm to that radius; without radii it stays on the line.
// With lookAroundDeg > 0 the view turns smoothly (yaw and pitch, each within
// +-lookAroundDeg) away from the look-ahead direction. Throws InputError if
// the path has fewer than two distinct points or an option is out of range.
// Throws InputError naming the scene key ("camera.path.wander", ...) for an option out of range.
void validate(const FlyThrough& options);
std::vector<Pose> flyThrough(const std::vector<Vec3>& centerline, const FlyThrough& options,
                             const std::vector<float>& radii = {});

// A bronchoscopist's survey of a whole centerline tree (docs/theory.md, "The
// bronchoscopist's survey"): down every branch to its distal end and back,
// depth first, as an airway inspection goes. The scope advances slowly into a
// branch, pauses at its end looking around, withdraws (faster, still looking
// distally, as a scope cannot turn round) to just above the carina, pauses
// there turning towards the next orifice, and enters it. All the way the tip
// keeps off the centre (FlyThrough::wander of the lumen's radius, never
// closer than wallClearanceMm to the wall), the view turns towards the walls
// (lookAroundDeg) and the scope rolls (rollDeg). Time runs in millimetres of
// advance: speedMm per frame (0: the frames spread over the whole survey),
// the waves' periods wanderPeriodMm. `stopMm` is the gap kept before each
// leaf's distal end on top of its radius there (a blind end's cap). Leaves
// shorter than their radius are not entered. Throws InputError for a tree
// without branches or options out of range.
struct Survey {
    float rollDeg = 30.0f;       // the scope's roll about its axis: within +-rollDeg (0..90)
    float pauseMm = 10.0f;       // each pause lasts as long as advancing this far
    float withdrawSpeed = 2.5f;  // withdrawing is this many times faster than advancing (>= 1)
    float carinaBackoff = 0.6f;  // the withdrawal stops this many parent radii above a carina
};
void validate(const Survey& survey);
std::vector<Pose> surveyTree(const mesh::Centerline& tree, const FlyThrough& fly, const Survey& survey, float stopMm);

// Length of a polyline (mm).
float pathLength(const std::vector<Vec3>& polyline);

}  // namespace mucosa::camera
