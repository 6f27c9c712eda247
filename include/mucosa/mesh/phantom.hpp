#pragma once
// The built-in airway phantom: a synthetic bronchial tree, watertight, with
// normals facing the lumen, centerline UVs and tangents (docs/theory.md,
// "Airway phantom").
#include <cstdint>
#include <functional>
#include <string_view>

#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh {

// Axes of the phantom (millimetres): origin at the top (cranial end) of the
// trachea's centerline, +Y cranial (up), +X the patient's left, +Z anterior;
// the trachea runs down -Y to the carina.
struct PhantomParams {
    int generations = 3;          // 1 main bronchi, 2 lobar, 3 segmental, ... (0..7)
    std::uint64_t seed = 1;       // jitter of angles, lengths and branching planes beyond the lobar bronchi
    double resolution = 2.0;      // grid cells per millimetre (0.5 mm voxels)
    double tracheaDiameter = 18;  // mm
    double tracheaLength = 110;   // mm
    bool cartilageRings = true;   // C-shaped ring ridges on the trachea and main bronchi
    bool uvs = true;              // centerline UVs and tangents
};

struct Phantom {
    Mesh mesh;
    Centerline centerline;
};

// progress(fraction 0..1, stage) is called from the calling thread.
using Progress = std::function<void(double fraction, std::string_view stage)>;

// Throws InputError for parameters out of range and ResourceError when the
// grid would not fit in memory (checked before allocating).
Phantom makePhantom(const PhantomParams& params, int threads = 0, const Progress& progress = {});

// Only the centerline tree (cheap; the same tree makePhantom builds).
Centerline phantomCenterline(const PhantomParams& params);

// The cartilage rings of a phantom (docs/theory.md, "Airway phantom"): no two
// alike. Each ring: its centre along the tube (mm from the tube's start),
// its height relative to the mean ridge, its plane's tilt (mm of axial shift
// at the lumen's edge) towards `tiltAngle` (radians around the wall from the
// anterior direction, positive towards the tube's e2 = direction x
// anterior), and where its C's gap begins (the cosine of the angle from the
// anterior direction below which the posterior membranous wall has none).
struct CartilageRing {
    double s = 0, height = 1, tilt = 0, tiltAngle = 0, gap = -0.625;
};
struct TubeRings {
    int branch = 0;                    // index into the centerline's branches
    double radius = 0;                 // the tube's radius at its start (mm)
    double halfWidth = 0;              // each ridge's half-width along the tube (mm)
    double heightMm = 0;               // the mean ridge's height into the lumen (mm) at height 1
    std::vector<CartilageRing> rings;  // in order along the tube
    // The ridge at axial s and angle theta (radians from anterior, towards
    // e2), relative: the highest ring's raised cosine x its height x its C,
    // 0 between rings and on the membranous wall (before the fade near the
    // tube's ends).
    double ridge(double s, double theta) const;
};
std::vector<TubeRings> phantomRings(const PhantomParams& params);

}  // namespace mucosa::mesh
