// Centerline UVs for tubes and branching tubes (level-set diagram, Lazarus &
// Verroust 1999): geodesic distance from the proximal end, rings of equal
// distance, their centroids as the centerline, angle around it and arc length
// along it as (u, v). computeCenterlineUvs at the end reads as its phases.
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
// Ring centroids are averaged over +-kSmoothNodes rings along a branch with
// tent weights (kSmoothNodes + 1 - |k|): as much smoothing, and as much pull
// towards the middle at a branch's ends, as a flat window of +-kFlatNodes.
// The centerline reported (flight paths) keeps the flat window: it pulls the
// rings of a short branch (a closed end) to one point away from the wall.
constexpr int kSmoothNodes = 9;
constexpr int kFlatNodes = 6;

std::uint32_t findRoot(std::vector<std::uint32_t>& parent, std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
}

struct Node {
    int slice = 0;  // level index k (distance (k + 1/2) w)
    std::uint32_t piece = 0;
    int parent = -1;  // node in a lower slice
    int branch = -1;
    int indexInBranch = 0;  // its place in Branch::nodes
    std::vector<int> children;
    Vec3d sum{0, 0, 0};
    std::size_t count = 0;
    Vec3d c{}, t{}, n{}, b{};  // centroid and frame
    Vec3d path{};              // centroid smoothed with the flat window (Centerline output)
    double s = 0;              // arc length at the centroid (mm)
    double v = 0;              // texture v at the centroid
};

struct Branch {
    std::vector<int> nodes;  // proximal to distal
    int parent = -1;
    double radius = 0;
    int wraps = 1;
    double vRate = 0;  // texture v per mm along the branch
};

// The mesh's connectivity on welded positions.
struct Topology {
    const Mesh& mesh;
    std::vector<std::uint32_t> ids;  // vertex -> welded representative
    std::vector<EdgeUse> edges;      // sorted by (a, b)
    std::vector<std::uint32_t> deg;  // CSR offsets into adj
    std::vector<std::uint32_t> adj;
    std::vector<char> isRep;  // a welded representative used by a triangle
    std::size_t vertexCount() const noexcept { return mesh.vertexCount(); }
    Vec3d P(std::uint32_t v) const { return toD(mesh.positions[v]); }
    std::size_t edgeIndex(std::uint32_t a, std::uint32_t b) const {
        if (a > b) std::swap(a, b);
        const auto it = std::lower_bound(edges.begin(), edges.end(), std::pair{a, b},
                                         [](const EdgeUse& e, const std::pair<std::uint32_t, std::uint32_t>& k) {
                                             return std::pair{e.a, e.b} < k;
                                         });
        return static_cast<std::size_t>(it - edges.begin());
    }
};

// Connected pieces and where each starts: its highest vertex along `up`.
struct Pieces {
    std::vector<std::uint32_t> uf;      // union-find over positions: piece = findRoot(uf, v)
    std::vector<std::uint32_t> loopUf;  // union-find over boundary edges: loop = findRoot(loopUf, v)
    std::vector<char> onBoundary;
    std::map<std::uint32_t, std::vector<std::uint32_t>> loops;  // loop root -> vertices
    std::map<std::uint32_t, std::uint32_t> top;                 // piece -> proximal vertex
};

struct Geodesic {
    std::vector<double> dist;
    std::vector<std::uint32_t> pred;  // Dijkstra predecessor (UINT32_MAX at the sources)
};

// The level-set diagram: rings (nodes) at distances (k + 1/2) w, the ring of
// each vertex, and the parent links.
struct Rings {
    double w = 1;  // slice width (mm)
    std::vector<Node> nodes;
    std::unordered_map<std::uint64_t, std::uint32_t> crossingId;  // (edge, level) -> crossing
    std::vector<std::uint32_t> crossingEdge;
    std::vector<int> crossingLevel;
    std::vector<int> nodeOfCrossing;
    std::vector<int> nodeOf;  // vertex -> node (-1: none)
    std::vector<int> order;   // nodes by slice: parents before children
    int levelBelow(double d) const { return static_cast<int>(std::floor(d / w - 0.5)); }  // -1 before the first
    double levelValue(int k) const { return (k + 0.5) * w; }
    static std::uint64_t key(std::size_t edge, int level) { return (std::uint64_t(edge) << 24) | std::uint64_t(level); }
};

void unite(std::vector<std::uint32_t>& uf, std::uint32_t a, std::uint32_t b) {
    a = findRoot(uf, a), b = findRoot(uf, b);
    if (a != b) uf[std::max(a, b)] = std::min(a, b);
}

Topology buildTopology(const Mesh& mesh) {
    Topology t{mesh, {}, {}, {}, {}, {}};
    const std::size_t nv = mesh.vertexCount();
    positionIds(mesh, t.ids);
    t.edges = edgeUses(mesh, t.ids);
    t.deg.assign(nv + 1, 0);
    for (const EdgeUse& e : t.edges) ++t.deg[e.a + 1], ++t.deg[e.b + 1];
    for (std::size_t v = 0; v < nv; ++v) t.deg[v + 1] += t.deg[v];
    t.adj.resize(t.deg[nv]);
    std::vector<std::uint32_t> fill(t.deg.begin(), t.deg.end() - 1);
    for (const EdgeUse& e : t.edges) t.adj[fill[e.a]++] = e.b, t.adj[fill[e.b]++] = e.a;
    t.isRep.assign(nv, 0);
    for (std::uint32_t i : mesh.indices) t.isRep[t.ids[i]] = 1;
    return t;
}

Pieces findPieces(const Topology& t, const Vec3d& up) {
    const std::size_t nv = t.vertexCount();
    Pieces p;
    p.uf.resize(nv);
    std::iota(p.uf.begin(), p.uf.end(), 0u);
    for (const EdgeUse& e : t.edges) unite(p.uf, e.a, e.b);
    // Boundary loops: boundary edges grouped into loops.
    p.loopUf.resize(nv);
    std::iota(p.loopUf.begin(), p.loopUf.end(), 0u);
    p.onBoundary.assign(nv, 0);
    for (const EdgeUse& e : t.edges)
        if (e.count == 1) {
            p.onBoundary[e.a] = p.onBoundary[e.b] = 1;
            unite(p.loopUf, e.a, e.b);
        }
    for (std::uint32_t v = 0; v < nv; ++v)
        if (p.onBoundary[v]) p.loops[findRoot(p.loopUf, v)].push_back(v);
    for (std::uint32_t v = 0; v < nv; ++v) {
        if (!t.isRep[v]) continue;
        const std::uint32_t piece = findRoot(p.uf, v);
        auto it = p.top.find(piece);
        if (it == p.top.end() || dot(t.P(v), up) > dot(t.P(it->second), up)) p.top[piece] = v;
    }
    return p;
}

// Geodesic distance (Dijkstra on edges) from each piece's proximal end: its
// highest vertex along `up`, or the whole boundary loop through it.
Geodesic geodesicFromProximalEnds(const Topology& t, Pieces& pieces) {
    const std::size_t nv = t.vertexCount();
    Geodesic g{std::vector<double>(nv, INFINITY), std::vector<std::uint32_t>(nv, UINT32_MAX)};
    using Item = std::pair<double, std::uint32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
    for (const auto& [piece, top] : pieces.top) {
        if (pieces.onBoundary[top]) {
            for (std::uint32_t v : pieces.loops[findRoot(pieces.loopUf, top)]) g.dist[v] = 0, queue.push({0.0, v});
        } else {
            g.dist[top] = 0;
            queue.push({0.0, top});
        }
    }
    while (!queue.empty()) {
        const auto [d, v] = queue.top();
        queue.pop();
        if (d > g.dist[v]) continue;
        for (std::uint32_t k = t.deg[v]; k < t.deg[v + 1]; ++k) {
            const std::uint32_t u = t.adj[k];
            const double nd = d + length(t.P(u) - t.P(v));
            if (nd < g.dist[u]) g.dist[u] = nd, g.pred[u] = v, queue.push({nd, u});
        }
    }
    return g;
}

// Rings: the contours of the distance at levels (k + 1/2) w. A contour is a
// set of crossed edges; two crossings of one level in one triangle belong to
// the same ring (union-find). A ring's centroid is the mean of its crossings.
void traceRings(const Topology& t, Pieces& pieces, const Geodesic& g, Rings& r) {
    const Mesh& mesh = t.mesh;
    std::vector<std::uint32_t> cuf;
    auto crossing = [&](std::size_t e, int k) {
        auto [it, inserted] =
            r.crossingId.try_emplace(Rings::key(e, k), static_cast<std::uint32_t>(r.crossingEdge.size()));
        if (inserted) {
            r.crossingEdge.push_back(static_cast<std::uint32_t>(e));
            r.crossingLevel.push_back(k);
            cuf.push_back(it->second);
        }
        return it->second;
    };
    for (std::size_t tri = 0; tri < mesh.triangleCount(); ++tri) {
        const std::uint32_t c[3] = {t.ids[mesh.indices[3 * tri]], t.ids[mesh.indices[3 * tri + 1]],
                                    t.ids[mesh.indices[3 * tri + 2]]};
        if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) continue;
        const double dmin = std::min({g.dist[c[0]], g.dist[c[1]], g.dist[c[2]]}),
                     dmax = std::max({g.dist[c[0]], g.dist[c[1]], g.dist[c[2]]});
        if (!std::isfinite(dmax)) continue;
        for (int k = r.levelBelow(dmin) + 1; r.levelValue(k) <= dmax; ++k) {
            const double lv = r.levelValue(k);
            std::uint32_t found[3];
            int nf = 0;
            for (int j = 0; j < 3; ++j) {
                const std::uint32_t a = c[j], b = c[(j + 1) % 3];
                if ((g.dist[a] < lv) != (g.dist[b] < lv)) found[nf++] = crossing(t.edgeIndex(a, b), k);
            }
            for (int j = 1; j < nf; ++j) unite(cuf, found[0], found[j]);
        }
    }
    r.nodeOfCrossing.assign(r.crossingEdge.size(), -1);
    for (std::uint32_t x = 0; x < r.crossingEdge.size(); ++x) {
        const std::uint32_t root = findRoot(cuf, x);
        if (r.nodeOfCrossing[root] < 0) {
            r.nodeOfCrossing[root] = static_cast<int>(r.nodes.size());
            r.nodes.push_back({});
            r.nodes.back().slice = r.crossingLevel[x];
            r.nodes.back().piece = findRoot(pieces.uf, t.edges[r.crossingEdge[x]].a);
        }
        r.nodeOfCrossing[x] = r.nodeOfCrossing[root];
        const EdgeUse& e = t.edges[r.crossingEdge[x]];
        const double lv = r.levelValue(r.crossingLevel[x]);
        const double f = std::clamp((lv - g.dist[e.a]) / (g.dist[e.b] - g.dist[e.a]), 0.0, 1.0);
        Node& n = r.nodes[std::size_t(r.nodeOfCrossing[x])];
        n.sum += t.P(e.a) + (t.P(e.b) - t.P(e.a)) * f;
        ++n.count;
    }
    for (Node& n : r.nodes) n.c = n.sum * (1.0 / double(n.count));
}

// Each vertex belongs to the ring just below it on its shortest path (follow
// the Dijkstra predecessor until the path crosses that level); each ring's
// parent is the ring below the lower ends of its crossed edges (majority);
// vertices before the first ring take the nearest first ring of their piece.
void linkRings(const Topology& t, Pieces& pieces, const Geodesic& g, Rings& r) {
    const std::size_t nv = t.vertexCount();
    std::vector<std::uint32_t> byDistance;
    for (std::uint32_t v = 0; v < nv; ++v)
        if (t.isRep[v] && std::isfinite(g.dist[v])) byDistance.push_back(v);
    std::sort(byDistance.begin(), byDistance.end(),
              [&](std::uint32_t a, std::uint32_t b) { return g.dist[a] < g.dist[b]; });
    r.nodeOf.assign(nv, -1);
    std::vector<std::uint32_t> firstLevelVertices;
    for (std::uint32_t v : byDistance) {
        const int k = r.levelBelow(g.dist[v]);
        if (k < 0 || g.pred[v] == UINT32_MAX) {
            firstLevelVertices.push_back(v);
            continue;
        }
        const std::uint32_t u = g.pred[v];
        if (g.dist[u] < r.levelValue(k)) {
            const auto it = r.crossingId.find(Rings::key(t.edgeIndex(u, v), k));
            r.nodeOf[v] = it != r.crossingId.end() ? r.nodeOfCrossing[it->second] : r.nodeOf[u];
        } else {
            r.nodeOf[v] = r.nodeOf[u];
        }
    }
    std::map<std::pair<int, int>, int> votes;
    for (std::uint32_t x = 0; x < r.crossingEdge.size(); ++x) {
        const EdgeUse& e = t.edges[r.crossingEdge[x]];
        const std::uint32_t lower = g.dist[e.a] < g.dist[e.b] ? e.a : e.b;
        const int par = r.nodeOf[lower];
        if (par >= 0 && r.nodes[std::size_t(par)].slice < r.crossingLevel[x]) ++votes[{r.nodeOfCrossing[x], par}];
    }
    std::vector<int> best(r.nodes.size(), 0);
    for (const auto& [key, count] : votes)
        if (count > best[std::size_t(key.first)])
            best[std::size_t(key.first)] = count, r.nodes[std::size_t(key.first)].parent = key.second;
    for (std::uint32_t v : firstLevelVertices) {
        double bestD = INFINITY;
        for (std::size_t i = 0; i < r.nodes.size(); ++i)
            if (r.nodes[i].slice == 0 && r.nodes[i].piece == findRoot(pieces.uf, v)) {
                const double d = length(r.nodes[i].c - t.P(v));
                if (d < bestD) bestD = d, r.nodeOf[v] = static_cast<int>(i);
            }
    }
    r.order.resize(r.nodes.size());
    std::iota(r.order.begin(), r.order.end(), 0);
    std::stable_sort(r.order.begin(), r.order.end(),
                     [&](int a, int b) { return r.nodes[std::size_t(a)].slice < r.nodes[std::size_t(b)].slice; });
    for (int i : r.order)
        if (r.nodes[std::size_t(i)].parent >= 0)
            r.nodes[std::size_t(r.nodes[std::size_t(i)].parent)].children.push_back(i);
}

// Branches: a chain continues while its node has one child; several children
// (the ring split at a bifurcation) start new branches.
std::vector<Branch> chainBranches(Rings& r) {
    std::vector<Branch> branches;
    for (int i : r.order) {
        Node& n = r.nodes[std::size_t(i)];
        const Node* par = n.parent >= 0 ? &r.nodes[std::size_t(n.parent)] : nullptr;
        if (par && par->children.size() == 1) {
            n.branch = par->branch;
        } else {
            n.branch = static_cast<int>(branches.size());
            branches.push_back({});
            branches.back().parent = par ? par->branch : -1;
        }
        n.indexInBranch = static_cast<int>(branches[std::size_t(n.branch)].nodes.size());
        branches[std::size_t(n.branch)].nodes.push_back(i);
    }
    return branches;
}

// Smooth the centroids along each branch (the rings are cut by a staircase of
// mesh edges), then frames by projection transport (a rotation-minimising
// frame to first order; Bishop 1975) and the arc length along the axis.
void smoothAndFrame(std::vector<Node>& nodes, const std::vector<Branch>& branches, const Vec3d& up) {
    for (const Branch& br : branches) {
        std::vector<Vec3d> smooth(br.nodes.size());
        for (std::size_t i = 0; i < br.nodes.size(); ++i) {
            Vec3d acc{0, 0, 0};
            double wsum = 0;
            // Weights falling off with the distance along the branch (a tent):
            // near a short branch's ends the window is cut on one side, and
            // flat weights then gave neighbouring rings the same mean (no
            // length between them along the axis).
            for (int k = -kSmoothNodes; k <= kSmoothNodes; ++k) {
                const auto j = static_cast<std::ptrdiff_t>(i) + k;
                if (j < 0 || j >= static_cast<std::ptrdiff_t>(br.nodes.size())) continue;
                const Node& m = nodes[std::size_t(br.nodes[std::size_t(j)])];
                const double weight = double(m.count) * double(kSmoothNodes + 1 - std::abs(k));
                acc += m.c * weight;
                wsum += weight;
            }
            smooth[i] = acc * (1.0 / wsum);
            Vec3d flat{0, 0, 0};
            double flatSum = 0;
            for (int k = -kFlatNodes; k <= kFlatNodes; ++k) {
                const auto j = static_cast<std::ptrdiff_t>(i) + k;
                if (j < 0 || j >= static_cast<std::ptrdiff_t>(br.nodes.size())) continue;
                const Node& m = nodes[std::size_t(br.nodes[std::size_t(j)])];
                flat += m.c * double(m.count);
                flatSum += double(m.count);
            }
            nodes[std::size_t(br.nodes[i])].path = flat * (1.0 / flatSum);
        }
        for (std::size_t i = 0; i < br.nodes.size(); ++i) nodes[std::size_t(br.nodes[i])].c = smooth[i];
    }
    for (const Branch& br : branches) {
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
}

// Radii, the tile length L, and square texels: a branch wraps the texture
// round(2 pi r / L) times (at least once) and runs along at the same rate,
// wraps / (2 pi r) per mm; v at each ring. Returns L.
double tileBranches(const Topology& t, Rings& r, std::vector<Branch>& branches, double tileLength) {
    std::vector<double> radiusSum(branches.size(), 0.0);
    std::vector<std::size_t> radiusCount(branches.size(), 0);
    for (std::uint32_t v = 0; v < t.vertexCount(); ++v) {
        if (r.nodeOf[v] < 0) continue;
        const Node& n = r.nodes[std::size_t(r.nodeOf[v])];
        const Vec3d d = t.P(v) - n.c;
        radiusSum[std::size_t(n.branch)] += length(d - n.t * dot(d, n.t));
        ++radiusCount[std::size_t(n.branch)];
    }
    double widest = 0;
    for (std::size_t b = 0; b < branches.size(); ++b) {
        branches[b].radius = radiusCount[b] ? radiusSum[b] / double(radiusCount[b]) : 0;
        // Only branches with a real ring count for the widest tube.
        if (branches[b].nodes.size() >= 3) widest = std::max(widest, branches[b].radius);
    }
    const double L = tileLength > 0 ? tileLength : std::max(kTwoPi * widest, 1e-3);
    for (Branch& br : branches) {
        br.wraps = std::max(1, static_cast<int>(std::lround(kTwoPi * br.radius / L)));
        br.vRate = br.radius > 0 ? br.wraps / (kTwoPi * br.radius) : 1.0 / L;
    }
    for (int i : r.order) {
        Node& n = r.nodes[std::size_t(i)];
        const Node* par = n.parent >= 0 ? &r.nodes[std::size_t(n.parent)] : nullptr;
        n.v = par ? par->v + (n.s - par->s) * branches[std::size_t(n.branch)].vRate : 0.0;
    }
    return L;
}

// The branch's axis at the cross-section through p: each ring's centroid
// and frame define a plane across the tube; between two consecutive rings p
// lies on the plane interpolated linearly between theirs (signed distances
// d0 >= 0 > d1, lambda = d0 / (d0 - d1)), so the centre, frame and v vary
// continuously over the surface instead of jumping from one ring to the
// next (the jumps folded thin triangles). Before the branch's first ring or
// past its last, that ring's frame. The walk starts at `start`.
struct AxisFrame {
    Vec3d c, t, n, b;
    double v;
};

AxisFrame axisFrameAt(const std::vector<Node>& nodes, const Branch& br, const Vec3d& p, const Node& start) {
    const int count = static_cast<int>(br.nodes.size());
    auto at = [&](int i) -> const Node& { return nodes[std::size_t(br.nodes[std::size_t(i)])]; };
    auto d = [&](int i) { return dot(p - at(i).c, at(i).t); };
    int j = start.indexInBranch;
    for (int guard = 0; guard < 4 * count; ++guard) {
        if (j > 0 && d(j) < 0)
            --j;
        else if (j + 1 < count && d(j + 1) >= 0)
            ++j;
        else
            break;
    }
    const Node& a = at(j);
    if (j + 1 >= count || d(j) < 0) return {a.c, a.t, a.n, a.b, a.v};
    const Node& b = at(j + 1);
    const double d0 = d(j), d1 = d(j + 1);
    const double lambda = d0 - d1 > 0 ? std::clamp(d0 / (d0 - d1), 0.0, 1.0) : 0.0;
    AxisFrame f;
    f.c = a.c + (b.c - a.c) * lambda;
    f.t = normalizeOr(a.t + (b.t - a.t) * lambda, a.t);
    const Vec3d n0 = a.n + (b.n - a.n) * lambda;
    f.n = normalizeOr(n0 - f.t * dot(f.t, n0), a.n);
    f.b = cross(f.t, f.n);
    f.v = a.v + (b.v - a.v) * lambda;
    return f;
}

// The mesh with (u, v): u = wraps * angle / 2 pi around the branch's axis
// (axisFrameAt), v along it at the branch's rate. Each triangle belongs to
// one chart: its branch and the sense of its angle. A vertex is split where
// triangles need it in another chart or on the other side of the wrap-around
// seam: one vertex per (vertex, branch, sense, lifted).
Mesh assignUvs(const Topology& t, const Rings& r, const std::vector<Branch>& branches, std::size_t& seamVertices) {
    const Mesh& mesh = t.mesh;
    auto nearestNodeOfBranch = [&](int branch, const Vec3d& p) -> const Node& {
        const Branch& br = branches[std::size_t(branch)];
        int best = br.nodes.front();
        double bestD = INFINITY;
        for (int i : br.nodes) {
            const double d = length(r.nodes[std::size_t(i)].c - p);
            if (d < bestD) bestD = d, best = i;
        }
        return r.nodes[std::size_t(best)];
    };
    const std::size_t nv = t.vertexCount();
    Mesh out;
    out.indices.resize(mesh.indices.size());
    std::unordered_map<std::uint64_t, std::uint32_t> variant;  // (vertex, branch, lifted)
    variant.reserve(nv + nv / 4);
    seamVertices = 0;
    const bool normals = mesh.hasNormals(), colors = mesh.hasColors();
    std::vector<char> firstUse(nv, 0);
    // Two passes over the triangles: the first sums each branch's facing, the
    // second places the corners.
    std::vector<double> branchFacing(branches.size(), 0.0);
    auto visit = [&](std::size_t tri, bool place) {
        std::uint32_t vi[3];
        int br[3];
        for (int k = 0; k < 3; ++k) {
            vi[k] = mesh.indices[3 * tri + k];
            const int nd = r.nodeOf[t.ids[vi[k]]];
            br[k] = nd >= 0 ? r.nodes[std::size_t(nd)].branch : 0;
        }
        // The triangle's branch: the majority, else the lowest index.
        int B = std::min({br[0], br[1], br[2]});
        if (br[1] == br[2]) B = br[1];
        if (br[0] == br[1] || br[0] == br[2]) B = br[0];
        // Each corner's cross-section of the triangle's branch (the walk
        // starts at the corner's own ring, or the nearest ring of that branch).
        // (No ring at all -- a mesh smaller than a slice -- leaves every
        // corner at (0, 0) in an empty branch.)
        static const Branch kNoBranch{};
        const Branch& branch = branches.empty() ? kNoBranch : branches[std::size_t(B)];
        AxisFrame frame[3];
        bool has[3];
        for (int k = 0; k < 3; ++k) {
            const int nd = r.nodeOf[t.ids[vi[k]]];
            has[k] = nd >= 0;
            if (!has[k]) continue;
            const Vec3d p = toD(mesh.positions[vi[k]]);
            frame[k] =
                axisFrameAt(r.nodes, branch, p, br[k] == B ? r.nodes[std::size_t(nd)] : nearestNodeOfBranch(B, p));
        }
        // Which way this triangle faces its branch's axis: outward (away
        // from it) or inward (a lumen seen from inside). The angle runs the
        // other way on a branch that faces inward, so (u, v) follow the
        // triangles' counter-clockwise winding.
        const Vec3d P0 = toD(mesh.positions[vi[0]]), P1 = toD(mesh.positions[vi[1]]), P2 = toD(mesh.positions[vi[2]]);
        const Vec3d centre = (P0 + P1 + P2) * (1.0 / 3.0);
        double facing = 0;
        for (int k = 0; k < 3; ++k)
            if (has[k]) {
                const Vec3d radial = centre - frame[k].c - frame[k].t * dot(centre - frame[k].c, frame[k].t);
                facing += dot(cross(P1 - P0, P2 - P0), normalizeOr(radial, Vec3d{0, 0, 0}));
            }
        // (u, v) of the corners for one sense of the angle, the low side of a
        // triangle across the wrap-around seam lifted by one period.
        const double period = branch.wraps;
        std::array<double, 2> uv[3];
        int lifted[3];
        auto uvFor = [&](int sense) {
            for (int k = 0; k < 3; ++k) {
                lifted[k] = 0;
                if (!has[k]) {
                    uv[k] = {0, 0};
                    continue;
                }
                const AxisFrame& f = frame[k];
                const Vec3d dd = toD(mesh.positions[vi[k]]) - f.c;
                double theta = std::atan2((sense ? -1.0 : 1.0) * dot(dd, f.b), dot(dd, f.n));
                if (theta < 0) theta += kTwoPi;
                uv[k] = {branch.wraps * theta / kTwoPi, f.v + dot(dd, f.t) * branch.vRate};
            }
            const double umax = std::max({uv[0][0], uv[1][0], uv[2][0]}),
                         umin = std::min({uv[0][0], uv[1][0], uv[2][0]});
            if (umax - umin > 0.5 * period)
                for (int k = 0; k < 3; ++k)
                    if (uv[k][0] < 0.5 * period) uv[k][0] += period, lifted[k] = 1;
            return (uv[1][0] - uv[0][0]) * (uv[2][1] - uv[0][1]) - (uv[2][0] - uv[0][0]) * (uv[1][1] - uv[0][1]);
        };
        if (!place) {
            if (!branches.empty()) branchFacing[std::size_t(B)] += facing;
            return;
        }
        // A triangle that faces the other way than most of its branch (the
        // inner wall of a thick shell, a closed end, a carina's crest) would
        // fold over: it takes the other sense, a chart of its own, and its
        // vertices are split from its neighbours' along the border.
        int sense = !branches.empty() && branchFacing[std::size_t(B)] < 0 ? 1 : 0;
        if (uvFor(sense) < 0) {
            if (uvFor(1 - sense) > 0)
                sense = 1 - sense;
            else
                uvFor(sense);
        }
        for (int k = 0; k < 3; ++k) {
            const std::uint64_t key = (std::uint64_t(vi[k]) << 32) | (std::uint64_t(B) << 2) |
                                      (std::uint64_t(sense) << 1) | std::uint64_t(lifted[k]);
            auto [it, inserted] = variant.try_emplace(key, static_cast<std::uint32_t>(out.positions.size()));
            if (inserted) {
                out.positions.push_back(mesh.positions[vi[k]]);
                if (normals) out.normals.push_back(mesh.normals[vi[k]]);
                if (colors) out.colors.push_back(mesh.colors[vi[k]]);
                out.uvs.push_back({static_cast<float>(uv[k][0]), static_cast<float>(uv[k][1])});
                if (firstUse[vi[k]]) ++seamVertices;
                firstUse[vi[k]] = 1;
            }
            out.indices[3 * tri + k] = it->second;
        }
    };
    for (std::size_t tri = 0; tri < mesh.triangleCount(); ++tri) visit(tri, false);
    for (std::size_t tri = 0; tri < mesh.triangleCount(); ++tri) visit(tri, true);
    return out;
}

// The centerline the UVs follow: one branch per chain of rings.
Centerline centerlineOf(const Rings& r, const std::vector<Branch>& branches) {
    Centerline c;
    c.axes = "as the mesh";
    for (std::size_t b = 0; b < branches.size(); ++b) {
        const Branch& br = branches[b];
        CenterlineBranch cb;
        cb.name = fmt::format("branch {}", b);
        cb.parent = br.parent;
        for (int i : br.nodes) {
            cb.points.push_back(toF(r.nodes[std::size_t(i)].path));
            cb.radii.push_back(static_cast<float>(br.radius));
        }
        cb.generation = br.parent >= 0 ? c.branches[std::size_t(br.parent)].generation + 1 : 0;
        c.branches.push_back(std::move(cb));
    }
    return c;
}

}  // namespace

CenterlineUvReport computeCenterlineUvs(Mesh& mesh, const CenterlineUvOptions& opt) {
    validateIndices(mesh);
    if (mesh.triangleCount() == 0) throw InputError("centerline UVs", "", "the mesh has no triangles");
    for (const Vec3& p : mesh.positions)
        if (!finite(p)) throw InputError("centerline UVs", "", "the mesh has non-finite positions");
    requireMemory(saturatingMul(mesh.vertexCount(), 160) + saturatingMul(mesh.indices.size(), 48), "centerline UVs");

    const Topology topology = buildTopology(mesh);
    const Vec3d up = normalizeOr(toD(opt.up), Vec3d{0, 1, 0});
    Pieces pieces = findPieces(topology, up);
    const Geodesic geodesic = geodesicFromProximalEnds(topology, pieces);
    Rings rings;
    double meanEdge = 0;
    for (const EdgeUse& e : topology.edges) meanEdge += length(topology.P(e.a) - topology.P(e.b));
    meanEdge /= static_cast<double>(std::max<std::size_t>(1, topology.edges.size()));
    rings.w = opt.sliceWidth > 0 ? opt.sliceWidth : std::max(3.0 * meanEdge, 1e-6);
    traceRings(topology, pieces, geodesic, rings);
    linkRings(topology, pieces, geodesic, rings);
    std::vector<Branch> branches = chainBranches(rings);
    smoothAndFrame(rings.nodes, branches, up);
    const double L = tileBranches(topology, rings, branches, opt.tileLength);

    CenterlineUvReport rep;
    Mesh out = assignUvs(topology, rings, branches, rep.seamVertices);
    out.materials = std::move(mesh.materials);  // assignUvs keeps the triangles' order
    rep.tileLength = static_cast<float>(L);
    rep.pieces = pieces.top.size();
    rep.centerline = centerlineOf(rings, branches);
    mesh = std::move(out);
    return rep;
}

}  // namespace mucosa::mesh
