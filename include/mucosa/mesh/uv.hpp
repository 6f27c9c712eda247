#pragma once
// Texture coordinates for tubes and branching tubes (airways) that have none.
#include <cstddef>

#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh {

struct CenterlineUvOptions {
    Vec3 up{0, 1, 0};      // each connected piece is parameterised from its end furthest along `up`
    float tileLength = 0;  // mm per texture repeat on the widest tube; 0 = its circumference
    float sliceWidth = 0;  // mm between centerline samples; 0 = auto (about 2 mean edge lengths)
};

struct CenterlineUvReport {
    Centerline centerline;         // the centerline the UVs follow (one branch per tube piece)
    float tileLength = 0;          // mm per texture repeat, as used
    std::size_t seamVertices = 0;  // vertices duplicated at the wrap-around seam and chart borders
    std::size_t pieces = 0;        // connected pieces parameterised
};

// Level-set centerline parameterisation (Lazarus & Verroust 1999, "Level set
// diagrams of polyhedral objects"): geodesic distance from the proximal end
// (the piece's highest point along `up`, or the boundary loop through it)
// slices each connected piece into rings; ring centroids form the centerline
// tree. u = angle around it x wraps / 2 pi, wraps = max(1, round(2 pi r /
// tileLength)) whole turns of the (tileable) map, so the wrap-around seam is
// invisible; v = arc length x wraps / (2 pi r): texels stay square on every
// branch (thin branches repeat the map at a finer scale). Each vertex is
// measured against the axis at its own cross-section (the ring frames
// interpolated between consecutive rings), so (u, v) vary continuously
// within a branch. The angle runs so that (u, v) follow the triangles'
// counter-clockwise winding (tangent w = +1) whichever way the surface faces:
// per branch, the way most of it faces its axis; a triangle that would fold
// over with that sense (the inner wall of a thick shell, a closed end, a
// carina's crest, edge-on to the axis) takes the other one. Charts: one per
// (branch, sense), with vertices duplicated along their borders, the
// branch junctions and the wrap-around seam. Triangles folded over (mucosa
// mesh info's "flipped"): 1 of 567 936 on the default phantom (a sliver that
// faces against its own vertex normals), 0 of 20 696 on the CT airway in
// tests/data; 9 432 and 2 324 before the interpolated frames and the charts.
// Replaces mesh.uvs, drops tangents (recompute them).
CenterlineUvReport computeCenterlineUvs(Mesh& mesh, const CenterlineUvOptions& options = {});

}  // namespace mucosa::mesh
