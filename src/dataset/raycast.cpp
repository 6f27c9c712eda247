// Exact ray casting against a mesh: see include/mucosa/dataset/raycast.hpp.
#include <mucosa/dataset/raycast.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>

namespace mucosa::dataset {

namespace {

constexpr int kBins = 16;
// Below this depth the tree splits by the SAH; beyond it (a pathological
// mesh) by the median, which halves every node, so the depth stays bounded.
constexpr int kMaxSahDepth = 48;
constexpr int kStackSize = 128;  // > kMaxSahDepth + 32 (median splits of 2^31 triangles)

// pbrt-v4's gamma(n) = n eps / (1 - n eps), eps half an ulp of 1 (Higham 2002,
// section 3.1): the relative error bound of n roundings.
constexpr double gamma(int n) {
    constexpr double eps = std::numeric_limits<double>::epsilon() * 0.5;
    return (n * eps) / (1 - n * eps);
}

struct Box {
    float lo[3] = {std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
                   std::numeric_limits<float>::infinity()};
    float hi[3] = {-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                   -std::numeric_limits<float>::infinity()};
    void grow(const Box& b) {
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], b.lo[k]), hi[k] = std::max(hi[k], b.hi[k]);
    }
    void grow(const float p[3]) {
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    }
    bool empty() const { return lo[0] > hi[0]; }
    double halfArea() const {
        if (empty()) return 0;
        const double dx = double(hi[0]) - lo[0], dy = double(hi[1]) - lo[1], dz = double(hi[2]) - lo[2];
        return dx * dy + dy * dz + dz * dx;
    }
};

struct Ref {
    Box box;
    float centre[3];
};

// The watertight test (Woop, Benthin & Wald 2013, section 3 and figure 2's
// listing) for a ray whose shear was set up by `Shear`.
struct Shear {
    int kx, ky, kz;
    double Sx, Sy, Sz;
    explicit Shear(const frames::Vec3d& d) {
        // kz: the dimension where the direction is largest; kx, ky the other
        // two, swapped for a negative direction to keep the winding.
        kz = std::fabs(d[0]) >= std::fabs(d[1]) ? (std::fabs(d[0]) >= std::fabs(d[2]) ? 0 : 2)
                                                : (std::fabs(d[1]) >= std::fabs(d[2]) ? 1 : 2);
        kx = (kz + 1) % 3;
        ky = (kx + 1) % 3;
        if (d[kz] < 0) std::swap(kx, ky);
        Sx = d[kx] / d[kz];
        Sy = d[ky] / d[kz];
        Sz = 1.0 / d[kz];
    }
};

// Woop et al. 2013's U, V, W are the weights of A, B, C: here p0, p1, p2.
inline bool watertight(const float* p, const frames::Vec3d& o, const Shear& s, double tMin, double tMax, Hit& hit) {
    const double A[3] = {double(p[0]) - o[0], double(p[1]) - o[1], double(p[2]) - o[2]};
    const double B[3] = {double(p[3]) - o[0], double(p[4]) - o[1], double(p[5]) - o[2]};
    const double C[3] = {double(p[6]) - o[0], double(p[7]) - o[1], double(p[8]) - o[2]};
    const double Ax = A[s.kx] - s.Sx * A[s.kz], Ay = A[s.ky] - s.Sy * A[s.kz];
    const double Bx = B[s.kx] - s.Sx * B[s.kz], By = B[s.ky] - s.Sy * B[s.kz];
    const double Cx = C[s.kx] - s.Sx * C[s.kz], Cy = C[s.ky] - s.Sy * C[s.kz];
    const double U = Cx * By - Cy * Bx;
    const double V = Ax * Cy - Ay * Cx;
    const double W = Bx * Ay - By * Ax;
    if ((U < 0 || V < 0 || W < 0) && (U > 0 || V > 0 || W > 0)) return false;
    const double det = U + V + W;
    if (det == 0) return false;  // the ray in the triangle's plane, or a degenerate triangle
    const double T = U * (s.Sz * A[s.kz]) + V * (s.Sz * B[s.kz]) + W * (s.Sz * C[s.kz]);
    const double t = T / det;
    if (!(t >= tMin && t <= tMax)) return false;
    hit.t = t;
    hit.b1 = V / det;
    hit.b2 = W / det;
    return true;
}

// The ray's entry into a node's box, or +inf where it misses [tMin, tMax].
// Conservative for rounding (Ize 2013; pbrt-v4 Bounds3::IntersectP): each
// far distance grows by 2 gamma(3). A zero direction component gives an
// infinite inverse; a NaN slab (the origin on that plane) is ignored.
inline double entry(const RayCaster::Node& n, const frames::Vec3d& o, const double inv[3], const bool neg[3],
                    double tMin, double tMax) {
    double tNear = tMin, tFar = tMax;
    for (int k = 0; k < 3; ++k) {
        double t0 = (double(n.lo[k]) - o[k]) * inv[k];
        double t1 = (double(n.hi[k]) - o[k]) * inv[k];
        if (neg[k]) std::swap(t0, t1);
        t1 += std::fabs(t1) * (2 * gamma(3));
        tNear = t0 > tNear ? t0 : tNear;
        tFar = t1 < tFar ? t1 : tFar;
    }
    return tNear <= tFar ? tNear : std::numeric_limits<double>::infinity();
}

struct Builder {
    std::vector<Ref>& refs;
    std::vector<std::uint32_t>& order;
    std::vector<RayCaster::Node>& nodes;
    int depth = 0;

    void leaf(std::size_t node, const Box& box, std::size_t begin, std::size_t end) {
        RayCaster::Node& n = nodes[node];
        std::copy(box.lo, box.lo + 3, n.lo);
        std::copy(box.hi, box.hi + 3, n.hi);
        n.index = static_cast<std::uint32_t>(begin);
        n.count = static_cast<std::uint32_t>(end - begin);
    }

    void build(std::size_t node, std::size_t begin, std::size_t end, int level) {
        depth = std::max(depth, level);
        Box box, centres;
        for (std::size_t i = begin; i < end; ++i) {
            box.grow(refs[order[i]].box);
            centres.grow(refs[order[i]].centre);
        }
        const std::size_t n = end - begin;
        if (n <= 2) return leaf(node, box, begin, end);

        // Binned SAH (Wald 2007, section 3): the split plane between bins
        // with the least A_L N_L + A_R N_R, over all three axes.
        double bestCost = std::numeric_limits<double>::infinity();
        int bestAxis = -1, bestBin = 0;
        for (int axis = 0; axis < 3 && level < kMaxSahDepth; ++axis) {
            const double lo = centres.lo[axis], extent = double(centres.hi[axis]) - lo;
            if (!(extent > 0)) continue;
            std::array<Box, kBins> bins;
            std::array<std::size_t, kBins> counts{};
            const double scale = kBins / extent;
            for (std::size_t i = begin; i < end; ++i) {
                const Ref& r = refs[order[i]];
                const int b = std::min(kBins - 1, static_cast<int>((r.centre[axis] - lo) * scale));
                bins[static_cast<std::size_t>(b)].grow(r.box);
                ++counts[static_cast<std::size_t>(b)];
            }
            // Right-hand sweep, then the left-hand one evaluating each plane.
            std::array<double, kBins> rightCost{};
            Box right;
            std::size_t rightCount = 0;
            for (int b = kBins - 1; b > 0; --b) {
                right.grow(bins[static_cast<std::size_t>(b)]);
                rightCount += counts[static_cast<std::size_t>(b)];
                rightCost[static_cast<std::size_t>(b)] = right.halfArea() * static_cast<double>(rightCount);
            }
            Box left;
            std::size_t leftCount = 0;
            for (int b = 0; b < kBins - 1; ++b) {
                left.grow(bins[static_cast<std::size_t>(b)]);
                leftCount += counts[static_cast<std::size_t>(b)];
                if (leftCount == 0 || leftCount == n) continue;
                const double cost =
                    left.halfArea() * static_cast<double>(leftCount) + rightCost[static_cast<std::size_t>(b) + 1];
                if (cost < bestCost) bestCost = cost, bestAxis = axis, bestBin = b;
            }
        }
        // SAH: a leaf costs n intersections; a split one traversal step
        // (about one intersection) plus its children's share.
        const double leafCost = static_cast<double>(n) * box.halfArea();
        if (bestAxis >= 0 && n <= static_cast<std::size_t>(kMaxLeafTriangles) && bestCost + box.halfArea() >= leafCost)
            return leaf(node, box, begin, end);

        std::size_t mid;
        if (bestAxis >= 0) {
            const double lo = centres.lo[bestAxis];
            const double scale = kBins / (double(centres.hi[bestAxis]) - lo);
            const auto it = std::partition(
                order.begin() + static_cast<std::ptrdiff_t>(begin), order.begin() + static_cast<std::ptrdiff_t>(end),
                [&](std::uint32_t i) {
                    const int b = std::min(kBins - 1, static_cast<int>((refs[i].centre[bestAxis] - lo) * scale));
                    return b <= bestBin;
                });
            mid = static_cast<std::size_t>(it - order.begin());
        } else if (n <= static_cast<std::size_t>(kMaxLeafTriangles)) {
            return leaf(node, box, begin, end);  // every centre in one place: nothing to split
        } else {
            // The median along the centres' longest axis (ties by index), or
            // the middle of the range where the centres coincide.
            int axis = 0;
            for (int k = 1; k < 3; ++k)
                if (double(centres.hi[k]) - centres.lo[k] > double(centres.hi[axis]) - centres.lo[axis]) axis = k;
            mid = begin + n / 2;
            std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(begin),
                             order.begin() + static_cast<std::ptrdiff_t>(mid),
                             order.begin() + static_cast<std::ptrdiff_t>(end), [&](std::uint32_t a, std::uint32_t b) {
                                 return refs[a].centre[axis] < refs[b].centre[axis] ||
                                        (refs[a].centre[axis] == refs[b].centre[axis] && a < b);
                             });
        }
        MUCOSA_CHECK(mid > begin && mid < end, "a BVH split leaves a side empty");
        const std::size_t children = nodes.size();
        nodes.emplace_back();
        nodes.emplace_back();
        {
            RayCaster::Node& inner = nodes[node];
            std::copy(box.lo, box.lo + 3, inner.lo);
            std::copy(box.hi, box.hi + 3, inner.hi);
            inner.index = static_cast<std::uint32_t>(children);
            inner.count = 0;
        }
        build(children, begin, mid, level + 1);
        build(children + 1, mid, end, level + 1);
    }
};

}  // namespace

RayCaster::RayCaster(const mesh::Mesh& mesh) : mesh_(&mesh) {
    const std::size_t count = mesh.triangleCount();
    if (count > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw InputError("mesh", "ray casting", fmt::format("has {} triangles; at most 2^31 - 1", count));
    for (const std::uint32_t i : mesh.indices)
        if (i >= mesh.positions.size())
            throw InputError("mesh", "ray casting",
                             fmt::format("has a triangle index {} past its {} vertices", i, mesh.positions.size()));
    // References (36 bytes), order (4), the tree's at most 2n - 1 nodes (32
    // each), the triangles in leaf order (36) and their ids (4).
    requireMemory(saturatingMul(count, 36 + 4 + 64 + 36 + 4), "the ray caster's tree");
    triangles_.reserve(count);
    ids_.reserve(count);
    if (count == 0) return;

    std::vector<Ref> refs(count);
    for (std::size_t t = 0; t < count; ++t) {
        Box b;
        for (int k = 0; k < 3; ++k) b.grow(mesh.positions[mesh.indices[3 * t + k]].data());
        refs[t].box = b;
        for (int k = 0; k < 3; ++k) refs[t].centre[k] = 0.5f * (b.lo[k] + b.hi[k]);
    }
    std::vector<std::uint32_t> order(count);
    std::iota(order.begin(), order.end(), 0u);
    nodes_.reserve(2 * count - 1);
    nodes_.emplace_back();
    Builder builder{refs, order, nodes_};
    builder.build(0, 0, count, 1);
    depth_ = builder.depth;
    nodes_.shrink_to_fit();
    for (const std::uint32_t t : order) {
        std::array<float, 9> p;
        for (int k = 0; k < 3; ++k)
            for (int c = 0; c < 3; ++c)
                p[static_cast<std::size_t>(3 * k + c)] = mesh.positions[mesh.indices[3 * t + k]][c];
        triangles_.push_back(p);
        ids_.push_back(static_cast<std::int32_t>(t));
    }
}

std::optional<Hit> RayCaster::firstHit(const frames::Vec3d& o, const frames::Vec3d& d, double tMin, double tMax) const {
    if (nodes_.empty() || !(d[0] != 0 || d[1] != 0 || d[2] != 0)) return std::nullopt;
    const Shear shear(d);
    double inv[3];
    bool neg[3];
    for (int k = 0; k < 3; ++k) {
        inv[k] = 1.0 / d[k];
        neg[k] = std::signbit(inv[k]);
    }
    Hit best;
    double bestT = tMax;
    struct Entry {
        std::uint32_t node;
        double tNear;
    };
    Entry stack[kStackSize];
    int sp = 0;
    if (entry(nodes_[0], o, inv, neg, tMin, bestT) == std::numeric_limits<double>::infinity()) return std::nullopt;
    std::uint32_t node = 0;
    for (;;) {
        const Node& n = nodes_[node];
        if (n.count > 0) {
            for (std::uint32_t i = n.index; i < n.index + n.count; ++i) {
                Hit h;
                if (!watertight(triangles_[i].data(), o, shear, tMin, bestT, h)) continue;
                // Equal distances: the lower index, whatever the tree's order.
                if (best.triangle >= 0 && h.t == bestT && ids_[i] > best.triangle) continue;
                h.triangle = ids_[i];
                best = h;
                bestT = h.t;
            }
        } else {
            const std::uint32_t a = n.index, b = n.index + 1;
            const double ta = entry(nodes_[a], o, inv, neg, tMin, bestT);
            const double tb = entry(nodes_[b], o, inv, neg, tMin, bestT);
            const bool hitA = ta != std::numeric_limits<double>::infinity();
            const bool hitB = tb != std::numeric_limits<double>::infinity();
            if (hitA && hitB) {
                // Nearer first; the other waits on the stack with its entry distance.
                const bool aFirst = ta <= tb;
                MUCOSA_CHECK(sp < kStackSize, "the ray caster's stack overflowed");
                stack[sp++] = {aFirst ? b : a, aFirst ? tb : ta};
                node = aFirst ? a : b;
                continue;
            }
            if (hitA || hitB) {
                node = hitA ? a : b;
                continue;
            }
        }
        // The next waiting node the ray can still reach before the best hit.
        for (;;) {
            if (sp == 0) return best.triangle >= 0 ? std::optional<Hit>(best) : std::nullopt;
            const Entry e = stack[--sp];
            if (e.tNear <= bestT) {
                node = e.node;
                break;
            }
        }
    }
}

std::optional<Hit> intersectTriangle(const mesh::Mesh& mesh, std::int32_t triangle, const frames::Vec3d& origin,
                                     const frames::Vec3d& dir, double tMin, double tMax) {
    if (!(dir[0] != 0 || dir[1] != 0 || dir[2] != 0)) return std::nullopt;
    float p[9];
    for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c)
            p[3 * k + c] = mesh.positions[mesh.indices[3 * static_cast<std::size_t>(triangle) + k]][c];
    Hit h;
    if (!watertight(p, origin, Shear(dir), tMin, tMax, h)) return std::nullopt;
    h.triangle = triangle;
    return h;
}

}  // namespace mucosa::dataset
