// Centerline UVs for tubes and branching tubes (level-set diagram, Lazarus &
// Verroust 1999): geodesic distance from the proximal end, rings of equal
// distance, their centroids as the centerline, angle around it and arc length
// along it as (u, v).
#include <mucosa/mesh/uv.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <numeric>
#include <queue>
#include <unordered_map>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/mesh/io.hpp>

#include "adjacency.hpp"
#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;

namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;
// Ring centroids are averaged over +-kSmoothNodes rings along a branch.
constexpr int kSmoothNodes = 6;

std::uint32_t findRoot(std::vector<std::uint32_t>& parent, std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
}

struct Node {
    int slice = 0;  // level index k (distance (k + 1/2) w)
    std::uint32_t piece = 0;
    int parent = -1;  // node in a lower slice
    int branch = -1;
    std::vector<int> children;
    Vec3d sum{0, 0, 0};
    std::size_t count = 0;
    Vec3d c{}, t{}, n{}, b{};  // centroid and frame
    double s = 0;              // arc length at the centroid (mm)
    double v = 0;              // texture v at the centroid
};

struct Branch {
    std::vector<int> nodes;  // proximal to distal
    int parent = -1;
    double radius = 0;
    int wraps = 1;
};

}  // namespace

CenterlineUvReport computeCenterlineUvs(Mesh& mesh, const CenterlineUvOptions& opt) {
    validateIndices(mesh);
    if (mesh.triangleCount() == 0) throw InputError("centerline UVs", "", "the mesh has no triangles");
    for (const Vec3& p : mesh.positions)
        if (!finite(p)) throw InputError("centerline UVs", "", "the mesh has non-finite positions");
    const std::size_t nv = mesh.vertexCount();
    requireMemory(saturatingMul(nv, 160) + saturatingMul(mesh.indices.size(), 48), "centerline UVs");

    // Topology on welded positions.
    std::vector<std::uint32_t> ids;
    positionIds(mesh, ids);
    const std::vector<EdgeUse> edges = edgeUses(mesh, ids);
    std::vector<std::uint32_t> deg(nv + 1, 0);
    for (const EdgeUse& e : edges) ++deg[e.a + 1], ++deg[e.b + 1];
    for (std::size_t v = 0; v < nv; ++v) deg[v + 1] += deg[v];
    std::vector<std::uint32_t> adj(deg[nv]);
    {
        std::vector<std::uint32_t> fill(deg.begin(), deg.end() - 1);
        for (const EdgeUse& e : edges) adj[fill[e.a]++] = e.b, adj[fill[e.b]++] = e.a;
    }
    const Vec3d up = normalizeOr(toD(opt.up), Vec3d{0, 1, 0});
    auto P = [&](std::uint32_t w) { return toD(mesh.positions[w]); };
    double meanEdge = 0;
    for (const EdgeUse& e : edges) meanEdge += length(P(e.a) - P(e.b));
    meanEdge /= static_cast<double>(std::max<std::size_t>(1, edges.size()));
    const double w = opt.sliceWidth > 0 ? opt.sliceWidth : std::max(3.0 * meanEdge, 1e-6);

    // Pieces (connected through shared positions) and their seeds.
    std::vector<std::uint32_t> uf(nv);
    std::iota(uf.begin(), uf.end(), 0u);
    for (const EdgeUse& e : edges) {
        const std::uint32_t a = findRoot(uf, e.a), b = findRoot(uf, e.b);
        if (a != b) uf[std::max(a, b)] = std::min(a, b);
    }
    std::vector<char> isRep(nv, 0);  // welded representative used by a triangle
    for (std::uint32_t i : mesh.indices) isRep[ids[i]] = 1;
    std::map<std::uint32_t, std::vector<std::uint32_t>> boundaryByPiece;
    // Boundary loops: group boundary edges into loops per piece.
    std::vector<std::uint32_t> buf(nv);
    std::iota(buf.begin(), buf.end(), 0u);
    std::vector<char> onBoundary(nv, 0);
    for (const EdgeUse& e : edges)
        if (e.count == 1) {
            onBoundary[e.a] = onBoundary[e.b] = 1;
            const std::uint32_t a = findRoot(buf, e.a), b = findRoot(buf, e.b);
            if (a != b) buf[std::max(a, b)] = std::min(a, b);
        }
    std::map<std::uint32_t, std::vector<std::uint32_t>> loops;  // loop root -> vertices
    for (std::uint32_t v = 0; v < nv; ++v)
        if (onBoundary[v]) loops[findRoot(buf, v)].push_back(v);
    std::map<std::uint32_t, std::uint32_t> topVertex;
    for (std::uint32_t v = 0; v < nv; ++v) {
        if (!isRep[v]) continue;
        const std::uint32_t piece = findRoot(uf, v);
        auto it = topVertex.find(piece);
        if (it == topVertex.end() || dot(P(v), up) > dot(P(it->second), up)) topVertex[piece] = v;
    }

    // Geodesic distance (Dijkstra on edges) from each piece's proximal end:
    // its highest vertex along `up`, or the whole boundary loop through it.
    std::vector<double> dist(nv, INFINITY);
    std::vector<std::uint32_t> pred(nv, UINT32_MAX);
    using Item = std::pair<double, std::uint32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
    for (const auto& [piece, top] : topVertex) {
        if (onBoundary[top]) {
            for (std::uint32_t v : loops[findRoot(buf, top)]) dist[v] = 0, queue.push({0.0, v});
        } else {
            dist[top] = 0;
            queue.push({0.0, top});
        }
    }
    while (!queue.empty()) {
        const auto [d, v] = queue.top();
        queue.pop();
        if (d > dist[v]) continue;
        for (std::uint32_t k = deg[v]; k < deg[v + 1]; ++k) {
            const std::uint32_t u = adj[k];
            const double nd = d + length(P(u) - P(v));
            if (nd < dist[u]) dist[u] = nd, pred[u] = v, queue.push({nd, u});
        }
    }

    // Rings: the contours of the distance at levels (k + 1/2) w. A contour is
    // a set of crossed edges; two crossings of one level in one triangle
    // belong to the same ring (union-find).
    auto levelBelow = [&](double d) { return static_cast<int>(std::floor(d / w - 0.5)); };  // -1 before the first
    auto levelValue = [&](int k) { return (k + 0.5) * w; };
    auto edgeIndex = [&](std::uint32_t a, std::uint32_t b) -> std::size_t {
        if (a > b) std::swap(a, b);
        const auto it = std::lower_bound(edges.begin(), edges.end(), std::pair{a, b},
                                         [](const EdgeUse& e, const std::pair<std::uint32_t, std::uint32_t>& k) {
                                             return std::pair{e.a, e.b} < k;
                                         });
        return static_cast<std::size_t>(it - edges.begin());
    };
    std::unordered_map<std::uint64_t, std::uint32_t> crossingId;  // (edge, level) -> crossing
    std::vector<std::uint32_t> crossingEdge;
    std::vector<int> crossingLevel;
    std::vector<std::uint32_t> cuf;
    auto crossing = [&](std::size_t e, int k) {
        const std::uint64_t key = (std::uint64_t(e) << 24) | std::uint64_t(k);
        auto [it, inserted] = crossingId.try_emplace(key, static_cast<std::uint32_t>(crossingEdge.size()));
        if (inserted) {
            crossingEdge.push_back(static_cast<std::uint32_t>(e));
            crossingLevel.push_back(k);
            cuf.push_back(it->second);
        }
        return it->second;
    };
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
        const std::uint32_t c[3] = {ids[mesh.indices[3 * t]], ids[mesh.indices[3 * t + 1]],
                                    ids[mesh.indices[3 * t + 2]]};
        if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) continue;
        const double dmin = std::min({dist[c[0]], dist[c[1]], dist[c[2]]}),
                     dmax = std::max({dist[c[0]], dist[c[1]], dist[c[2]]});
        if (!std::isfinite(dmax)) continue;
        for (int k = levelBelow(dmin) + 1; levelValue(k) <= dmax; ++k) {
            const double lv = levelValue(k);
            std::uint32_t found[3];
            int nf = 0;
            for (int j = 0; j < 3; ++j) {
                const std::uint32_t a = c[j], b = c[(j + 1) % 3];
                if ((dist[a] < lv) != (dist[b] < lv)) found[nf++] = crossing(edgeIndex(a, b), k);
            }
            for (int j = 1; j < nf; ++j) {
                const std::uint32_t a = findRoot(cuf, found[0]), b = findRoot(cuf, found[j]);
                if (a != b) cuf[std::max(a, b)] = std::min(a, b);
            }
        }
    }
    std::vector<Node> nodes;
    std::vector<int> nodeOfCrossing(crossingEdge.size(), -1);
    for (std::uint32_t x = 0; x < crossingEdge.size(); ++x) {
        const std::uint32_t r = findRoot(cuf, x);
        if (nodeOfCrossing[r] < 0) {
            nodeOfCrossing[r] = static_cast<int>(nodes.size());
            nodes.push_back({});
            nodes.back().slice = crossingLevel[x];
            nodes.back().piece = findRoot(uf, edges[crossingEdge[x]].a);
        }
        nodeOfCrossing[x] = nodeOfCrossing[r];
        const EdgeUse& e = edges[crossingEdge[x]];
        const double lv = levelValue(crossingLevel[x]);
        const double f = std::clamp((lv - dist[e.a]) / (dist[e.b] - dist[e.a]), 0.0, 1.0);
        Node& n = nodes[std::size_t(nodeOfCrossing[x])];
        n.sum += P(e.a) + (P(e.b) - P(e.a)) * f;
        ++n.count;
    }
    for (Node& n : nodes) n.c = n.sum * (1.0 / double(n.count));

    // Each vertex belongs to the ring just below it on its shortest path:
    // follow the Dijkstra predecessor until the path crosses that level.
    std::vector<std::uint32_t> byDistance;
    for (std::uint32_t v = 0; v < nv; ++v)
        if (isRep[v] && std::isfinite(dist[v])) byDistance.push_back(v);
    std::sort(byDistance.begin(), byDistance.end(),
              [&](std::uint32_t a, std::uint32_t b) { return dist[a] < dist[b]; });
    std::vector<int> nodeOf(nv, -1);
    std::vector<std::uint32_t> firstLevelVertices;
    for (std::uint32_t v : byDistance) {
        const int k = levelBelow(dist[v]);
        if (k < 0 || pred[v] == UINT32_MAX) {
            firstLevelVertices.push_back(v);
            continue;
        }
        const std::uint32_t u = pred[v];
        if (dist[u] < levelValue(k)) {
            const auto it = crossingId.find((std::uint64_t(edgeIndex(u, v)) << 24) | std::uint64_t(k));
            nodeOf[v] = it != crossingId.end() ? nodeOfCrossing[it->second] : nodeOf[u];
        } else {
            nodeOf[v] = nodeOf[u];
        }
    }
    // Parent ring: the ring below the lower end of its crossed edges (majority).
    {
        std::map<std::pair<int, int>, int> votes;
        for (std::uint32_t x = 0; x < crossingEdge.size(); ++x) {
            const EdgeUse& e = edges[crossingEdge[x]];
            const std::uint32_t lower = dist[e.a] < dist[e.b] ? e.a : e.b;
            const int par = nodeOf[lower];
            if (par >= 0 && nodes[std::size_t(par)].slice < crossingLevel[x]) ++votes[{nodeOfCrossing[x], par}];
        }
        std::vector<int> best(nodes.size(), 0);
        for (const auto& [key, count] : votes)
            if (count > best[std::size_t(key.first)])
                best[std::size_t(key.first)] = count, nodes[std::size_t(key.first)].parent = key.second;
    }
    // Vertices before the first ring take the nearest first ring of their piece.
    for (std::uint32_t v : firstLevelVertices) {
        double bestD = INFINITY;
        for (std::size_t i = 0; i < nodes.size(); ++i)
            if (nodes[i].slice == 0 && nodes[i].piece == findRoot(uf, v)) {
                const double d = length(nodes[i].c - P(v));
                if (d < bestD) bestD = d, nodeOf[v] = static_cast<int>(i);
            }
    }
    // Visit nodes in slice order: parents before children.
    std::vector<int> order(nodes.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return nodes[std::size_t(a)].slice < nodes[std::size_t(b)].slice; });
    for (int i : order)
        if (nodes[std::size_t(i)].parent >= 0) nodes[std::size_t(nodes[std::size_t(i)].parent)].children.push_back(i);

    // Branches: a chain continues while its node has one child; several
    // children (the ring split at a bifurcation) start new branches.
    std::vector<Branch> branches;
    for (int i : order) {
        Node& n = nodes[std::size_t(i)];
        const Node* par = n.parent >= 0 ? &nodes[std::size_t(n.parent)] : nullptr;
        if (par && par->children.size() == 1) {
            n.branch = par->branch;
        } else {
            n.branch = static_cast<int>(branches.size());
            branches.push_back({});
            branches.back().parent = par ? par->branch : -1;
        }
        branches[std::size_t(n.branch)].nodes.push_back(i);
    }

    // Smooth the centroids along each branch (the rings are cut by a
    // staircase of mesh edges), then frames by projection transport (a
    // rotation-minimising frame to first order; Bishop 1975).
    for (Branch& br : branches) {
        std::vector<Vec3d> smooth(br.nodes.size());
        for (std::size_t i = 0; i < br.nodes.size(); ++i) {
            Vec3d acc{0, 0, 0};
            double wsum = 0;
            for (int k = -kSmoothNodes; k <= kSmoothNodes; ++k) {
                const auto j = static_cast<std::ptrdiff_t>(i) + k;
                if (j < 0 || j >= static_cast<std::ptrdiff_t>(br.nodes.size())) continue;
                const Node& m = nodes[std::size_t(br.nodes[std::size_t(j)])];
                acc += m.c * double(m.count);
                wsum += double(m.count);
            }
            smooth[i] = acc * (1.0 / wsum);
        }
        for (std::size_t i = 0; i < br.nodes.size(); ++i) nodes[std::size_t(br.nodes[i])].c = smooth[i];
    }
    for (Branch& br : branches) {
        for (std::size_t i = 0; i < br.nodes.size(); ++i) {
            Node& n = nodes[std::size_t(br.nodes[i])];
            const Node* par = n.parent >= 0 ? &nodes[std::size_t(n.parent)] : nullptr;
            const Vec3d prev = i > 0 ? nodes[std::size_t(br.nodes[i - 1])].c : (par ? par->c : n.c);
            const Vec3d next = i + 1 < br.nodes.size() ? nodes[std::size_t(br.nodes[i + 1])].c : n.c;
            Vec3d t = next - prev;
            if (!(length(t) > 1e-9)) t = par ? par->t : up * -1.0;
            n.t = normalizeOr(t, Vec3d{0, -1, 0});
            const Vec3d n0 = par ? par->n : anyPerpendicular(n.t);
            n.n = normalizeOr(n0 - n.t * dot(n.t, n0), anyPerpendicular(n.t));
            n.b = cross(n.t, n.n);
            // Arc length along the axis (the lateral wobble of the rings does not count).
            n.s = par ? par->s + std::abs(dot(n.c - par->c, n.t)) : 0.0;
        }
    }

    // Radii and the tile length.
    std::vector<double> radiusSum(branches.size(), 0.0);
    std::vector<std::size_t> radiusCount(branches.size(), 0);
    for (std::uint32_t v = 0; v < nv; ++v) {
        if (nodeOf[v] < 0) continue;
        const Node& n = nodes[std::size_t(nodeOf[v])];
        const Vec3d d = P(v) - n.c;
        radiusSum[std::size_t(n.branch)] += length(d - n.t * dot(d, n.t));
        ++radiusCount[std::size_t(n.branch)];
    }
    double widest = 0;
    for (std::size_t b = 0; b < branches.size(); ++b) {
        branches[b].radius = radiusCount[b] ? radiusSum[b] / double(radiusCount[b]) : 0;
        // Only branches with a real ring count for the widest tube.
        if (branches[b].nodes.size() >= 3) widest = std::max(widest, branches[b].radius);
    }
    const double L = opt.tileLength > 0 ? opt.tileLength : std::max(kTwoPi * widest, 1e-3);
    // Square texels: a branch wraps the texture round(2 pi r / L) times (at
    // least once) and runs along at the same rate, wraps / (2 pi r) per mm.
    std::vector<double> vRate(branches.size());
    for (std::size_t b = 0; b < branches.size(); ++b) {
        Branch& br = branches[b];
        br.wraps = std::max(1, static_cast<int>(std::lround(kTwoPi * br.radius / L)));
        vRate[b] = br.radius > 0 ? br.wraps / (kTwoPi * br.radius) : 1.0 / L;
    }
    for (int i : order) {
        Node& n = nodes[std::size_t(i)];
        n.v = n.parent >= 0 ? nodes[std::size_t(n.parent)].v +
                                  (n.s - nodes[std::size_t(n.parent)].s) * vRate[std::size_t(n.branch)]
                            : 0.0;
    }

    // Which way each branch's surface faces: outward (away from its
    // centerline) or inward (a lumen seen from inside, or the inner wall of a
    // thick tube). The angle runs the other way on inward-facing branches, so
    // (u, v) keep the triangles' counter-clockwise orientation everywhere (no
    // mirrored texture, tangent w = +1).
    std::vector<double> facing(branches.size(), 0.0);
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
        const std::uint32_t c0 = ids[mesh.indices[3 * t]], c1 = ids[mesh.indices[3 * t + 1]],
                            c2 = ids[mesh.indices[3 * t + 2]];
        const int nd = nodeOf[c0];
        if (nd < 0) continue;
        const Node& n = nodes[std::size_t(nd)];
        const Vec3d centre = (P(c0) + P(c1) + P(c2)) * (1.0 / 3.0);
        const Vec3d radial = centre - n.c - n.t * dot(centre - n.c, n.t);
        facing[std::size_t(n.branch)] += dot(cross(P(c1) - P(c0), P(c2) - P(c0)), normalizeOr(radial, Vec3d{0, 0, 0}));
    }
    // (u, v) of a point in a node's frame: u = wraps * angle / 2 pi, v along at the branch's rate.
    auto uvAt = [&](const Vec3d& p, const Node& n) {
        const Vec3d d = p - n.c;
        const double sense = facing[std::size_t(n.branch)] < 0 ? -1.0 : 1.0;
        double theta = std::atan2(sense * dot(d, n.b), dot(d, n.n));
        if (theta < 0) theta += kTwoPi;
        const double wraps = branches[std::size_t(n.branch)].wraps;
        return std::array<double, 2>{wraps * theta / kTwoPi, n.v + dot(d, n.t) * vRate[std::size_t(n.branch)]};
    };
    auto nearestNodeOfBranch = [&](int branch, const Vec3d& p) -> const Node& {
        const Branch& br = branches[std::size_t(branch)];
        int best = br.nodes.front();
        double bestD = INFINITY;
        for (int i : br.nodes) {
            const double d = length(nodes[std::size_t(i)].c - p);
            if (d < bestD) bestD = d, best = i;
        }
        return nodes[std::size_t(best)];
    };

    // New vertices: one per (vertex, branch, wrapped) the triangles ask for.
    Mesh out;
    out.indices.resize(mesh.indices.size());
    std::unordered_map<std::uint64_t, std::uint32_t> variant;  // (vertex, branch, lifted)
    variant.reserve(nv + nv / 4);
    std::size_t seamVertices = 0;
    const bool normals = mesh.hasNormals();
    std::vector<char> firstUse(nv, 0);
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
        std::uint32_t vi[3];
        int br[3];
        for (int k = 0; k < 3; ++k) {
            vi[k] = mesh.indices[3 * t + k];
            const int nd = nodeOf[ids[vi[k]]];
            br[k] = nd >= 0 ? nodes[std::size_t(nd)].branch : 0;
        }
        // The triangle's branch: the majority, else the lowest index.
        int B = std::min({br[0], br[1], br[2]});
        if (br[1] == br[2]) B = br[1];
        if (br[0] == br[1] || br[0] == br[2]) B = br[0];
        std::array<double, 2> uv[3];
        for (int k = 0; k < 3; ++k) {
            const Vec3d p = toD(mesh.positions[vi[k]]);
            const int nd = nodeOf[ids[vi[k]]];
            if (nd < 0)
                uv[k] = {0, 0};
            else if (br[k] == B)
                uv[k] = uvAt(p, nodes[std::size_t(nd)]);
            else
                uv[k] = uvAt(p, nearestNodeOfBranch(B, p));
        }
        // Wrap-around seam: lift the low side by one period of the branch.
        const double period = branches.empty() ? 1.0 : branches[std::size_t(B)].wraps;
        const double umax = std::max({uv[0][0], uv[1][0], uv[2][0]}), umin = std::min({uv[0][0], uv[1][0], uv[2][0]});
        int lifted[3] = {0, 0, 0};
        if (umax - umin > 0.5 * period)
            for (int k = 0; k < 3; ++k)
                if (uv[k][0] < 0.5 * period) uv[k][0] += period, lifted[k] = 1;
        for (int k = 0; k < 3; ++k) {
            const std::uint64_t key = (std::uint64_t(vi[k]) << 32) | (std::uint64_t(B) << 1) | std::uint64_t(lifted[k]);
            auto [it, inserted] = variant.try_emplace(key, static_cast<std::uint32_t>(out.positions.size()));
            if (inserted) {
                out.positions.push_back(mesh.positions[vi[k]]);
                if (normals) out.normals.push_back(mesh.normals[vi[k]]);
                out.uvs.push_back({static_cast<float>(uv[k][0]), static_cast<float>(uv[k][1])});
                if (firstUse[vi[k]]) ++seamVertices;
                firstUse[vi[k]] = 1;
            }
            out.indices[3 * t + k] = it->second;
        }
    }

    CenterlineUvReport rep;
    rep.tileLength = static_cast<float>(L);
    rep.seamVertices = seamVertices;
    rep.pieces = topVertex.size();
    rep.centerline.axes = "as the mesh";
    std::vector<int> branchIndex(branches.size(), -1);
    for (std::size_t b = 0; b < branches.size(); ++b) {
        const Branch& br = branches[b];
        CenterlineBranch cb;
        cb.name = fmt::format("branch {}", b);
        cb.parent = br.parent;
        for (int i : br.nodes) {
            cb.points.push_back(toF(nodes[std::size_t(i)].c));
            cb.radii.push_back(static_cast<float>(br.radius));
        }
        cb.generation = br.parent >= 0 ? rep.centerline.branches[std::size_t(br.parent)].generation + 1 : 0;
        rep.centerline.branches.push_back(std::move(cb));
    }
    mesh = std::move(out);
    return rep;
}

}  // namespace mucosa::mesh
