#pragma once
// Which side of an airway surface a camera inside it sees, decided from the
// airway's centerline rather than from the winding alone (`mucosa mesh
// --orient lumen`, and the check behind `mucosa render`'s back-face warning).
//
// A camera in the lumen sees the first surface along each ray from where it
// stands. Rays from the centerline (every point of its longest tree -- the
// airway's; a separate closed piece has a level-set centerline of its own
// inside it -- in kLumenRayDirections directions spread evenly over the
// sphere) meet the lumen wall first; whether each first hit's triangle turns its front (its
// counter-clockwise winding) towards the ray's origin says which way the wall
// faces -- whatever the mesh is (a thin tube, or a thick-walled shell whose
// outer wall the camera never sees).
#include <cstddef>

#include <mucosa/dataset/ground_truth.hpp>
#include <mucosa/dataset/raycast.hpp>
#include <mucosa/mesh/centerline.hpp>
#include <mucosa/mesh/mesh.hpp>

namespace mucosa::dataset {

// Rays per centerline point (a Fibonacci sphere).
inline constexpr int kLumenRayDirections = 64;

// First hits of rays from a centerline, and how many of them see a
// triangle's front (its winding facing the ray's origin).
struct LumenView {
    std::size_t rays = 0, hits = 0, front = 0;
    double frontFraction() const noexcept { return hits ? double(front) / double(hits) : 0.0; }
};

LumenView viewFromCenterline(const RayCaster& caster, const mesh::Centerline& centerline, int threads = 0);

struct LumenOrientReport {
    std::size_t patches = 0;          // triangles connected across edges two triangles share with opposite windings
    std::size_t turnedPatches = 0;    // patches whose winding was reversed
    std::size_t turnedTriangles = 0;  // their triangles
    std::size_t unseenPatches = 0;    // patches no ray met first: left as they were
    std::size_t normalsTurned = 0;    // vertex normals negated to agree with the new winding
    LumenView before, after;          // the rays' first hits before and after
};

// Turns every patch whose triangles the centerline's rays see more from
// behind than from the front: its winding is reversed, so the surface's
// front faces the lumen. Then each vertex normal that points against the
// winding of its triangles is negated (normals into the lumen too), and
// tangents are dropped (recompute them). The result depends only on the
// mesh's positions, its triangles and the centerline, not on the winding it
// came with: a mesh turned inside out comes out the same. Throws InputError
// for a centerline without points.
LumenOrientReport orientToLumen(mesh::Mesh& mesh, const mesh::Centerline& centerline, int threads = 0);

// What a camera sees of a surface's unlit side: of the pixels where its
// ground truth `truth` sees a surface (valid and in view), those whose
// triangle turns its unlit side to the camera -- its winding normal times
// `litSide` (the scene's lit_side: +1 "front", -1 "back") points away from
// the eye at `eye`. Those render dark (their lit side faces away), or not at
// all where back faces are culled (a closed scene).
struct BackFaceView {
    std::size_t seen = 0, back = 0;
    double backFraction() const noexcept { return seen ? double(back) / double(seen) : 0.0; }
};

BackFaceView backFacesSeen(const GroundTruth& truth, const mesh::Mesh& mesh, const frames::Vec3d& eye, float litSide);

}  // namespace mucosa::dataset
