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

}  // namespace mucosa::mesh
