#pragma once
// Exact ray casting against a triangle mesh: the first triangle a ray meets,
// for per-pixel ground truth through any lens (ground_truth.hpp), where a
// z-buffer cannot follow the rays of a fisheye.
//
//  - A bounding volume hierarchy over the mesh's triangles, built once per
//    mesh: binned surface area heuristic (Wald 2007, "On fast Construction
//    of SAH-based Bounding Volume Hierarchies", 16 bins per axis), a flat
//    array of nodes whose children are adjacent, leaves of at most
//    kMaxLeafTriangles triangles. The build is serial and deterministic.
//  - Queries walk the tree iteratively, nearer child first, with the
//    ray-box test made conservative for rounding (Ize 2013, "Robust BVH Ray
//    Traversal"; pbrt-v4's Bounds3::IntersectP, tMax *= 1 + 2 gamma(3)).
//  - Triangles are tested with the watertight intersection of Woop, Benthin
//    & Wald 2013 ("Watertight Ray/Triangle Intersection", JCGT 2(1)) in
//    double precision: a ray through a shared edge or vertex hits at least
//    one of the triangles around it, never slips between them. Both faces
//    count. Equal distances go to the lower triangle index, so the answer
//    does not depend on the tree's layout.
//
// Queries are const and thread-safe. The caster keeps a reference to the
// mesh, which must outlive it and not change.
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include <mucosa/frames/frames.hpp>
#include <mucosa/mesh/mesh.hpp>

namespace mucosa::dataset {

// Where a ray meets a triangle: origin + t dir = b0 p0 + b1 p1 + b2 p2 with
// b0 = 1 - b1 - b2 (p0, p1, p2 the triangle's vertices in index order: the
// convention of raster::GBuffer's b1, b2), t in units of dir's length.
struct Hit {
    std::int32_t triangle = -1;
    double b1 = 0, b2 = 0;
    double t = 0;
};

// Triangles per leaf, at most.
inline constexpr int kMaxLeafTriangles = 8;

class RayCaster {
public:
    // Builds the tree. Throws InputError for a mesh with more than 2^31 - 1
    // triangles or an index past its vertices, ResourceError when the tree
    // would not fit in memory (checked before allocating).
    explicit RayCaster(const mesh::Mesh& mesh);

    // The nearest hit with tMin <= t <= tMax (dir need not be unit; t is in
    // its units); nullopt where the ray meets nothing there.
    std::optional<Hit> firstHit(const frames::Vec3d& origin, const frames::Vec3d& dir, double tMin = 0,
                                double tMax = std::numeric_limits<double>::infinity()) const;

    const mesh::Mesh& mesh() const noexcept { return *mesh_; }
    std::size_t nodeCount() const noexcept { return nodes_.size(); }
    int depth() const noexcept { return depth_; }  // the longest root-to-leaf path, in nodes

    // A flat node: its box (float, as the vertices are, so it is exact), then
    // for an interior node (count 0) the index of its first child (the second
    // follows it), for a leaf its first triangle in the caster's order.
    struct Node {
        float lo[3];
        std::uint32_t index;
        float hi[3];
        std::uint32_t count;
    };

private:
    const mesh::Mesh* mesh_;
    std::vector<Node> nodes_;
    std::vector<std::array<float, 9>> triangles_;  // the vertices, in leaf order
    std::vector<std::int32_t> ids_;                // the mesh's index of each, in leaf order
    int depth_ = 0;
};

// The hit of one triangle (the same test firstHit runs), without a tree:
// for brute-force checks. nullopt outside [tMin, tMax] or off the triangle.
std::optional<Hit> intersectTriangle(const mesh::Mesh& mesh, std::int32_t triangle, const frames::Vec3d& origin,
                                     const frames::Vec3d& dir, double tMin = 0,
                                     double tMax = std::numeric_limits<double>::infinity());

}  // namespace mucosa::dataset
