// The airway phantom: a Weibel-like bronchial tree of tubes joined by a smooth
// union of their implicit surfaces, polygonised by marching tetrahedra.
#include <mucosa/mesh/phantom.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/core/parallel.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/mesh/uv.hpp>

#include "marching_tetrahedra.hpp"
#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kMaxGenerations = 7;

// Ratios of a daughter's diameter to its parent's in an asymmetric dichotomy;
// 0.86^3 + 0.70^3 = 0.98, close to Murray's law d0^3 = d1^3 + d2^3 (Murray 1926).
constexpr double kMajorRatio = 0.86, kMinorRatio = 0.70;
// Length / diameter of conducting airways (Weibel 1963: about 3).
constexpr double kLengthPerDiameter = 3.0;
// Cartilage rings: spacing along the airway and depth as a fraction of the radius.
constexpr double kRingSpacing = 4.5, kRingDepth = 0.045;

struct Tube {
    Vec3d a, dir;  // start, unit direction
    double length = 0;
    double radius = 0;     // at the start
    double endRadius = 0;  // after the taper towards the children
    int parent = -1, generation = 0;
    bool leaf = true, rings = false;
    Vec3d planeNormal{0, 0, 1};  // normal of the plane it branched in
    std::string name;
    Vec3d end() const { return a + dir * length; }
};

Vec3d rotate(const Vec3d& v, const Vec3d& axis, double angle) {
    // Rodrigues' rotation formula.
    const double c = std::cos(angle), s = std::sin(angle);
    return v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1 - c));
}

// Murray's angle law for a bifurcation with radii r0 -> r1, r2 (Murray 1926;
// Kitaoka et al. 1999): cos(theta1) = (r0^4 + r1^4 - r2^4) / (2 r0^2 r1^2).
double murrayAngle(double r0, double r1, double r2) {
    const double c = (std::pow(r0, 4) + std::pow(r1, 4) - std::pow(r2, 4)) / (2 * r0 * r0 * r1 * r1);
    return std::acos(std::clamp(c, -1.0, 1.0));
}

std::vector<Tube> buildTree(const PhantomParams& p) {
    std::mt19937_64 rng(p.seed);
    std::uniform_real_distribution<double> jitter(-1.0, 1.0);
    std::vector<Tube> tubes;
    const double r0 = p.tracheaDiameter / 2;
    Tube trachea;
    trachea.a = {0, 0, 0};
    trachea.dir = {0, -1, 0};
    trachea.length = p.tracheaLength;
    trachea.radius = r0;
    trachea.rings = p.cartilageRings;
    trachea.name = "trachea";
    trachea.planeNormal = {0, 0, 1};  // the carina divides in the coronal plane
    tubes.push_back(trachea);
    if (p.generations < 1) return tubes;

    // Main bronchi (anatomical averages): the right is wider, shorter and
    // steeper (about 25 deg from the tracheal axis, 13 mm, 25 mm long), the
    // left narrower and longer (about 45 deg, 11 mm, 48 mm long).
    const double scale = p.tracheaDiameter / 18.0;
    struct Main {
        const char* name;
        double side, angleDeg, diameter, length;
    } mains[2] = {{"right main bronchus", -1, 25, 13, 25}, {"left main bronchus", +1, 45, 11, 48}};
    for (const Main& mb : mains) {
        Tube t;
        t.dir = rotate({0, -1, 0}, {0, 0, 1}, mb.side * mb.angleDeg * kPi / 180);
        t.radius = mb.diameter / 2 * scale;
        t.length = mb.length * scale;
        t.parent = 0;
        t.generation = 1;
        t.rings = p.cartilageRings;
        t.name = mb.name;
        t.planeNormal = {0, 0, 1};
        tubes.push_back(t);
    }
    // Asymmetric dichotomies below (Horsfield & Cumming 1968; Kitaoka 1999):
    // daughters 0.86 and 0.70 of the parent's diameter, Murray's angles, the
    // branching plane turned about 90 deg from the parent's, length 3 diameters.
    for (std::size_t first = 1, gen = 1; gen < static_cast<std::size_t>(p.generations); ++gen) {
        const std::size_t last = tubes.size();
        for (std::size_t pi = first; pi < last; ++pi) {
            const Tube parent = tubes[pi];
            const double r1 = parent.radius * kMajorRatio, r2 = parent.radius * kMinorRatio;
            const double th1 = murrayAngle(parent.radius, r1, r2), th2 = murrayAngle(parent.radius, r2, r1);
            // Candidate planes: the parent's turned by +-90 deg (+- jitter);
            // keep the one that sends the daughters down and away from the midline.
            double best = -1e300;
            Vec3d bestNormal{};
            const double twist = kPi / 2 + 0.35 * jitter(rng);
            for (double sgn : {1.0, -1.0}) {
                const Vec3d n = normalizeOr(rotate(parent.planeNormal, parent.dir, sgn * twist), Vec3d{0, 0, 1});
                double score = 0;
                for (double side : {1.0, -1.0}) {
                    const Vec3d d = rotate(parent.dir, n, side * (side > 0 ? th1 : th2));
                    score += -d[1] + 0.7 * std::abs(d[0]) * (d[0] * parent.end()[0] >= 0 ? 1 : -1);
                }
                if (score > best) best = score, bestNormal = n;
            }
            for (int child = 0; child < 2; ++child) {
                Tube t;
                const double side = (child == 0 ? 1.0 : -1.0);
                const double angle = (child == 0 ? th1 : th2) * (1 + 0.12 * jitter(rng));
                t.dir = normalizeOr(rotate(parent.dir, bestNormal, side * angle), parent.dir);
                t.radius = child == 0 ? r1 : r2;
                t.length = kLengthPerDiameter * 2 * t.radius * (1 + 0.15 * jitter(rng));
                t.parent = static_cast<int>(pi);
                t.generation = static_cast<int>(gen + 1);
                t.planeNormal = bestNormal;
                t.name = fmt::format("{}.{}", parent.name, child == 0 ? "major" : "minor");
                tubes.push_back(t);
            }
        }
        first = last;
    }
    // Taper each parent's end towards its widest child, then place each child
    // at its parent's end, shifted towards its own side so the outer walls
    // continue from parent to child (the carina stays a ridge, not a shelf).
    std::vector<double> widestChild(tubes.size(), 0.0);
    for (std::size_t i = 1; i < tubes.size(); ++i) {
        const auto pi = static_cast<std::size_t>(tubes[i].parent);
        tubes[pi].leaf = false;
        widestChild[pi] = std::max(widestChild[pi], tubes[i].radius);
    }
    for (std::size_t i = 0; i < tubes.size(); ++i)
        tubes[i].endRadius = tubes[i].leaf ? tubes[i].radius
                                           : std::min(tubes[i].radius, 0.5 * (tubes[i].radius + widestChild[i]) * 1.05);
    for (std::size_t i = 1; i < tubes.size(); ++i) {
        Tube& t = tubes[i];
        const Tube& parent = tubes[static_cast<std::size_t>(t.parent)];
        const Vec3d lateral = normalizeOr(t.dir - parent.dir * dot(t.dir, parent.dir), Vec3d{0, 0, 0});
        t.a = parent.end() + lateral * std::max(0.0, 0.8 * (parent.endRadius - t.radius));
    }
    return tubes;
}

double smoothstep(double e0, double e1, double x) {
    const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3 - 2 * t);
}

// Signed distance-like field of one tube: < 0 inside its lumen.
double tubeField(const Tube& t, const Vec3d& p) {
    const Vec3d ap = p - t.a;
    const double along = dot(ap, t.dir);
    const double s = std::clamp(along, 0.0, t.length);
    const Vec3d c = t.a + t.dir * s;
    const Vec3d radial = p - c;
    const double dist = length(radial);
    // Taper over the last 1.5 radii towards the children.
    const double taperStart = std::max(0.0, t.length - 1.5 * t.radius);
    double r = t.radius + (t.endRadius - t.radius) * smoothstep(taperStart, t.length, s);
    if (t.rings) {
        // C-shaped cartilage rings: ridges every kRingSpacing mm, absent on the
        // posterior membranous wall (-Z), fading near both ends. The profile
        // (raised cosine cubed: ~1.2 mm at half height) is wide enough for the
        // grid of `render`'s default phantom (1 cell/mm) to follow without the
        // sawtooth a narrower ridge (the sixth power, ~0.85 mm) showed there.
        const Vec3d rn = dist > 1e-9 ? radial * (1 / dist) : Vec3d{0, 0, 1};
        const double anterior = rn[2];
        const double cShape = smoothstep(-0.85, -0.55, anterior);
        const double ridge = std::pow(0.5 + 0.5 * std::cos(2 * kPi * s / kRingSpacing), 3);
        const double fade = smoothstep(0, 8, s) * smoothstep(0, 10, t.length - s);
        r *= 1 - kRingDepth * ridge * cShape * fade;
        // The membranous wall is flatter.
        r *= 1 - 0.07 * smoothstep(-0.5, -1.0, anterior) * fade;
    }
    double d = dist - r;
    if (!t.leaf) d = std::max(d, along - t.length);  // open end: the children continue it
    return d;
}

// Polynomial smooth minimum (Quilez 2013): min(a, b) - h^2 k / 4, h = max(k - |a - b|, 0) / k.
double smoothMin(double a, double b, double k) {
    const double h = std::max(k - std::abs(a - b), 0.0) / k;
    return std::min(a, b) - h * h * k * 0.25;
}

struct Field {
    const std::vector<Tube>* tubes;
    // Uniform buckets of candidate tubes.
    Vec3d lo;
    double cell = 8;
    std::size_t bx = 0, by = 0, bz = 0;
    std::vector<std::vector<std::uint16_t>> buckets;
    double far = 1e3;

    double operator()(const Vec3d& p) const {
        const auto ix = static_cast<std::ptrdiff_t>(std::floor((p[0] - lo[0]) / cell));
        const auto iy = static_cast<std::ptrdiff_t>(std::floor((p[1] - lo[1]) / cell));
        const auto iz = static_cast<std::ptrdiff_t>(std::floor((p[2] - lo[2]) / cell));
        if (ix < 0 || iy < 0 || iz < 0 || ix >= std::ptrdiff_t(bx) || iy >= std::ptrdiff_t(by) ||
            iz >= std::ptrdiff_t(bz))
            return far;
        const auto& list = buckets[std::size_t(ix) + bx * (std::size_t(iy) + by * std::size_t(iz))];
        double f = far;
        double kPrev = 0;
        bool first = true;
        for (std::uint16_t ti : list) {
            const Tube& t = (*tubes)[ti];
            const double d = tubeField(t, p);
            const double k = 0.35 * t.radius;
            if (first) {
                f = d, kPrev = k, first = false;
            } else {
                f = smoothMin(f, d, std::min(k, kPrev));
                if (d < f + 1e-12) kPrev = k;
            }
        }
        return f;
    }
};

Field makeField(const std::vector<Tube>& tubes, const Vec3d& lo, const Vec3d& hi) {
    Field F;
    F.tubes = &tubes;
    F.lo = lo;
    F.bx = std::size_t(std::ceil((hi[0] - lo[0]) / F.cell)) + 1;
    F.by = std::size_t(std::ceil((hi[1] - lo[1]) / F.cell)) + 1;
    F.bz = std::size_t(std::ceil((hi[2] - lo[2]) / F.cell)) + 1;
    F.buckets.resize(F.bx * F.by * F.bz);
    for (std::size_t ti = 0; ti < tubes.size(); ++ti) {
        const Tube& t = tubes[ti];
        const double reach = std::max(t.radius, t.endRadius) * 1.4 + 2.0;  // radius + smooth-union band
        Vec3d a = t.a, b = t.end();
        for (int k = 0; k < 3; ++k) {
            const double l = std::min(a[k], b[k]) - reach, h = std::max(a[k], b[k]) + reach;
            a[k] = l, b[k] = h;
        }
        auto clampIndex = [](double v, std::size_t n) {
            return static_cast<std::size_t>(std::clamp(v, 0.0, double(n - 1)));
        };
        const std::size_t x0 = clampIndex(std::floor((a[0] - lo[0]) / F.cell), F.bx),
                          x1 = clampIndex(std::floor((b[0] - lo[0]) / F.cell), F.bx);
        const std::size_t y0 = clampIndex(std::floor((a[1] - lo[1]) / F.cell), F.by),
                          y1 = clampIndex(std::floor((b[1] - lo[1]) / F.cell), F.by);
        const std::size_t z0 = clampIndex(std::floor((a[2] - lo[2]) / F.cell), F.bz),
                          z1 = clampIndex(std::floor((b[2] - lo[2]) / F.cell), F.bz);
        for (std::size_t z = z0; z <= z1; ++z)
            for (std::size_t y = y0; y <= y1; ++y)
                for (std::size_t x = x0; x <= x1; ++x)
                    F.buckets[x + F.bx * (y + F.by * z)].push_back(static_cast<std::uint16_t>(ti));
    }
    return F;
}

void checkParams(const PhantomParams& p) {
    if (p.generations < 0 || p.generations > kMaxGenerations)
        throw InputError("generations", "", fmt::format("{} is outside 0..{}", p.generations, kMaxGenerations));
    if (!(p.resolution >= 0.25 && p.resolution <= 16))
        throw InputError("resolution", "", fmt::format("{} cells/mm is outside 0.25..16", p.resolution));
    if (!(p.tracheaDiameter >= 4 && p.tracheaDiameter <= 40))
        throw InputError("trachea diameter", "", fmt::format("{} mm is outside 4..40", p.tracheaDiameter));
    if (!(p.tracheaLength >= 20 && p.tracheaLength <= 300))
        throw InputError("trachea length", "", fmt::format("{} mm is outside 20..300", p.tracheaLength));
}

Centerline toCenterline(const std::vector<Tube>& tubes) {
    Centerline c;
    c.axes =
        "millimetres; origin at the top of the trachea's centerline; +Y cranial (up), +X the patient's left, "
        "+Z anterior; the trachea runs down -Y";
    for (const Tube& t : tubes) {
        CenterlineBranch b;
        b.name = t.name;
        b.parent = t.parent;
        b.generation = t.generation;
        const int steps = std::max(2, static_cast<int>(std::ceil(t.length)));
        for (int i = 0; i <= steps; ++i) {
            const double s = t.length * i / steps;
            b.points.push_back(toF(t.a + t.dir * s));
            const double taperStart = std::max(0.0, t.length - 1.5 * t.radius);
            b.radii.push_back(
                static_cast<float>(t.radius + (t.endRadius - t.radius) * smoothstep(taperStart, t.length, s)));
        }
        c.branches.push_back(std::move(b));
    }
    return c;
}

}  // namespace

Centerline phantomCenterline(const PhantomParams& params) {
    checkParams(params);
    return toCenterline(buildTree(params));
}

Phantom makePhantom(const PhantomParams& params, int threads, const Progress& progress) {
    checkParams(params);
    auto report = [&](double f, std::string_view stage) {
        if (progress) progress(f, stage);
    };
    report(0.0, "bronchial tree");
    const std::vector<Tube> tubes = buildTree(params);

    Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (const Tube& t : tubes)
        for (const Vec3d& q : {t.a, t.end()})
            for (int k = 0; k < 3; ++k) {
                const double r = std::max(t.radius, t.endRadius);
                lo[k] = std::min(lo[k], q[k] - r), hi[k] = std::max(hi[k], q[k] + r);
            }
    const double h = 1.0 / params.resolution;
    ScalarGrid g;
    g.spacing = h;
    for (int k = 0; k < 3; ++k) {
        lo[k] -= 3 * h;
        hi[k] += 3 * h;
    }
    g.origin = lo;
    g.nx = static_cast<std::size_t>(std::ceil((hi[0] - lo[0]) / h)) + 1;
    g.ny = static_cast<std::size_t>(std::ceil((hi[1] - lo[1]) / h)) + 1;
    g.nz = static_cast<std::size_t>(std::ceil((hi[2] - lo[2]) / h)) + 1;
    const std::uint64_t samples = saturatingMul(saturatingMul(g.nx, g.ny), g.nz);
    // The grid, and a mesh of roughly 3 triangles per surface cell.
    requireMemory(saturatingMul(samples, sizeof(float)) + saturatingMul(samples, 4), "phantom grid");
    g.values.resize(samples);

    const Field F = makeField(tubes, lo, hi);
    report(0.05, "implicit surface");
    tbb::task_arena arena(resolveThreads(threads));
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, g.nz), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t k = r.begin(); k != r.end(); ++k)
                for (std::size_t j = 0; j < g.ny; ++j)
                    for (std::size_t i = 0; i < g.nx; ++i) {
                        const Vec3d p{lo[0] + h * double(i), lo[1] + h * double(j), lo[2] + h * double(k)};
                        float v = static_cast<float>(F(p));
                        if (v == 0.0f) v = 1e-7f;  // no sample on the surface: the result stays a manifold
                        // The border is outside so the surface closes.
                        if (i == 0 || j == 0 || k == 0 || i + 1 == g.nx || j + 1 == g.ny || k + 1 == g.nz)
                            v = std::max(v, 1e-3f);
                        g.values[i + g.nx * (j + g.ny * k)] = v;
                    }
        });
    });

    report(0.45, "marching tetrahedra");
    Phantom out;
    out.mesh = marchingTetrahedra(g);
    g.values = {};
    g.values.shrink_to_fit();

    report(0.65, "normals");
    // N = -grad f / |grad f| (central differences): towards the lumen.
    out.mesh.normals.resize(out.mesh.positions.size());
    const double e = 0.25 * h;
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, out.mesh.positions.size(), 1024),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t v = r.begin(); v != r.end(); ++v) {
                                  const Vec3d p = toD(out.mesh.positions[v]);
                                  Vec3d grad;
                                  for (int k = 0; k < 3; ++k) {
                                      Vec3d a = p, b = p;
                                      a[k] += e;
                                      b[k] -= e;
                                      grad[k] = (F(a) - F(b)) / (2 * e);
                                  }
                                  out.mesh.normals[v] = toF(normalizeOr(grad * -1.0, Vec3d{0, 1, 0}));
                              }
                          });
    });
    out.centerline = toCenterline(tubes);

    if (params.uvs) {
        report(0.75, "centerline UVs");
        CenterlineUvOptions uo;
        uo.up = {0, 1, 0};
        computeCenterlineUvs(out.mesh, uo);
        report(0.92, "tangents");
        computeTangents(out.mesh, threads);
    }
    report(1.0, "done");
    return out;
}

}  // namespace mucosa::mesh
