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
    std::size_t seamVertices = 0;  // vertices duplicated at the wrap-around seam and branch junctions
    std::size_t pieces = 0;        // connected pieces parameterised
};

// Level-set centerline parameterisation (Lazarus & Verroust 1999, "Level set
// diagrams of polyhedral objects"): geodesic distance from the proximal end
// (the piece's highest point along `up`, or the boundary loop through it)
// slices each connected piece into rings; ring centroids form the centerline
// tree. u = angle around it x wraps / 2 pi, wraps = max(1, round(2 pi r /
// tileLength)) whole turns of the (tileable) map, so the wrap-around seam is
// invisible; v = arc length x wraps / (2 pi r): texels stay square on every
// branch (thin branches repeat the map at a finer scale). The seam and branch
// junctions get duplicated vertices. The angle runs so that (u, v) follow
// the triangles' counter-clockwise winding (tangent w = +1) whichever way the
// surface faces. Replaces mesh.uvs, drops tangents (recompute them).
CenterlineUvReport computeCenterlineUvs(Mesh& mesh, const CenterlineUvOptions& options = {});

}  // namespace mucosa::mesh
