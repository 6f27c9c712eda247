#pragma once
// A tree of tube centerlines (points, radii, parent links): what the phantom is
// built from, what the centerline UVs follow, and what fly-through camera paths
// run along.
#include <filesystem>
#include <string>
#include <vector>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh {

struct CenterlineBranch {
    std::string name;          // "trachea", "right main bronchus", "b1.0.1", ...
    int parent = -1;           // index into Centerline::branches, -1 for the root
    int generation = 0;        // 0 trachea, 1 main bronchi, 2 lobar, 3 segmental (Weibel's z)
    std::vector<Vec3> points;  // mm, from the parent's end (proximal) to the distal end
    std::vector<float> radii;  // mm, one per point
};

struct Centerline {
    std::vector<CenterlineBranch> branches;  // parents before children
    std::string axes;                        // description of the frame, for the JSON
};

// JSON: {"units": "mm", "axes": ..., "branches": [{"name", "parent",
// "generation", "points": [[x,y,z],...], "radii": [...]}]}. Written atomically.
void writeCenterlineJson(const Centerline& centerline, const std::filesystem::path& path);
Centerline readCenterlineJson(const std::filesystem::path& path);  // InputError on malformed files

// A fly-through path: the points from the root to the distal end of `branch`.
std::vector<Vec3> pathToBranch(const Centerline& centerline, int branch);

}  // namespace mucosa::mesh
