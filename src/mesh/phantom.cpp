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
#include <mucosa/noise/perlin.hpp>

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
// Cartilage rings (Minnich & Mathisen 2007, "Anatomy of the trachea"; the
// bronchoscopic view in Ernst & Herth, "Principles and Practice of
// Interventional Pulmonology", 2013): 16-20 C-shaped rings over the
// trachea's ~11 cm, seen from the lumen as broad low whitish ridges with
// narrower furrows (the annular ligaments) between them. Period along the
// airway (mm; 22 rings on the trachea) and ridge height as a fraction of the
// radius (0.35 mm on the 9 mm trachea): the steepest flank then tilts 16 deg,
// so the distal flanks, seen at grazing angles down the tube, darken without
// drawing black lines (0.45 mm on a 4.5 mm period tilted 22 deg and read as
// grooves).
constexpr double kRingSpacing = 5.0, kRingHeight = 0.039;
// No two rings alike (Minnich & Mathisen 2007: rings fork, fuse and vary in
// width; bronchoscopically they are irregular, some barely raised under the
// mucosa): each ring's spacing from the last varies by up to +-kRingJitter
// of the mean, its height between kRingHeightMin and 1.3 of kRingHeight, its
// plane tilts by up to kRingTiltMm of axial shift across the lumen, and the
// gap of its C (the posterior membranous wall) starts at its own angle.
constexpr double kRingJitter = 0.3, kRingHeightMin = 0.35, kRingTiltMm = 1.2, kRingGapJitter = 0.15;
// Longitudinal folds of the posterior membranous wall (elastic fibre bundles
// under the mucosa): spacing around the wall (mm) and height as a fraction of
// the radius (0.2 mm on the trachea); wide enough for `render`'s 1 cell/mm.
constexpr double kFoldSpacing = 3.5, kFoldHeight = 0.022;
// Smooth-union width between a tube and its parent (a rounded flare), and
// between two siblings (the carina: a defined crest, Kitaoka et al. 1999),
// as fractions of the smaller radius.
constexpr double kJoinBlend = 0.35, kCarinaBlend = 0.08;

struct Tube {
    Vec3d a{0, 0, 0}, dir{0, -1, 0};  // start, unit direction of the chord
    // A gentle bend off the chord (mm): centre(s) = a + dir s + bendA (1 - cos(pi s / L)) / 2
    // + bendB sin^2(pi s / L); both leave the tangent at the ends equal to dir.
    Vec3d bendA{0, 0, 0}, bendB{0, 0, 0};
    // Cross-section frame: e1 anterior (the rings' C opens towards -e1), e2 = dir x e1;
    // the lumen is an ellipse whose radius shrinks by `ellipse` along eMinor.
    Vec3d e1{0, 0, 1}, e2{1, 0, 0}, eMinor{0, 0, 1};
    double ellipse = 0;
    double length = 0;
    double radius = 0;     // at the start
    double endRadius = 0;  // after the taper towards the children
    int parent = -1, generation = 0;
    bool leaf = true, rings = false;
    TubeRings ringList;          // the cartilage rings (when `rings`)
    Vec3d planeNormal{0, 0, 1};  // normal of the plane it branched in
    std::string name;
    bool bent() const { return dot(bendA, bendA) + dot(bendB, bendB) > 0; }
    Vec3d centre(double s) const {
        if (!bent()) return a + dir * s;
        const double x = kPi * s / length, sn = std::sin(x);
        return a + dir * s + bendA * (0.5 * (1 - std::cos(x))) + bendB * (sn * sn);
    }
    Vec3d tangent(double s) const {  // d centre / ds (not unit)
        if (!bent()) return dir;
        const double x = kPi * s / length, w = kPi / length;
        return dir + bendA * (0.5 * w * std::sin(x)) + bendB * (w * std::sin(2 * x));
    }
    double bendReach() const { return detail::length(bendA) + detail::length(bendB); }
    Vec3d end() const { return centre(length); }
};

// The cross-section frame: e1 the anterior direction (or `hint`) made
// orthogonal to the tube, e2 = dir x e1.
void setFrame(Tube& t, const Vec3d& hint) {
    Vec3d e1 = hint - t.dir * dot(hint, t.dir);
    e1 = normalizeOr(e1, normalizeOr(cross(t.dir, Vec3d{1, 0, 0}), Vec3d{0, 0, 1}));
    t.e1 = e1;
    t.e2 = cross(t.dir, e1);
}

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
    // The trachea is not a straight pipe: it follows the spine backwards and
    // the aortic arch, on its left, pushes its lower half to the right
    // (Minnich & Mathisen 2007). Its lumen is wider than deep (coronal >
    // sagittal in adults, Breatnach et al. 1984): 5 % shallower front to back.
    const double scale = p.tracheaDiameter / 18.0;
    trachea.bendA = Vec3d{-1.0, 0, -3.5} * scale;
    trachea.bendB = Vec3d{-1.8, 0, 0} * scale;
    setFrame(trachea, {0, 0, 1});
    trachea.eMinor = trachea.e1;
    trachea.ellipse = 0.05;
    tubes.push_back(trachea);
    if (p.generations < 1) return tubes;

    // Main bronchi (anatomical averages): the right is wider, shorter and
    // steeper (about 25 deg from the tracheal axis, 13 mm, 25 mm long), the
    // left narrower and longer (about 45 deg, 11 mm, 48 mm long).
    // Both also run slightly backwards (posterior), the right more: the tree
    // is not planar.
    struct Main {
        const char* name;
        double side, angleDeg, diameter, length, posteriorDeg, ellipseAngleDeg;
    } mains[2] = {{"right main bronchus", -1, 25, 13, 25, 10, 20}, {"left main bronchus", +1, 45, 11, 48, 6, -15}};
    for (const Main& mb : mains) {
        Tube t;
        const Vec3d inPlane = rotate({0, -1, 0}, {0, 0, 1}, mb.side * mb.angleDeg * kPi / 180);
        const double tilt = mb.posteriorDeg * kPi / 180;
        t.dir = normalizeOr(inPlane * std::cos(tilt) + Vec3d{0, 0, -1} * std::sin(tilt), inPlane);
        setFrame(t, {0, 0, 1});
        t.eMinor = rotate(t.e1, t.dir, mb.ellipseAngleDeg * kPi / 180);
        t.ellipse = 0.06;
        t.radius = mb.diameter / 2 * scale;
        t.length = mb.length * scale;
        t.parent = 0;
        t.a = tubes[0].end();  // provisional: buildTree's last step places every child
        t.generation = 1;
        t.rings = p.cartilageRings;
        t.name = mb.name;
        t.planeNormal = t.e1;
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
                t.a = parent.end();  // provisional, as for the main bronchi
                t.generation = static_cast<int>(gen + 1);
                t.planeNormal = normalizeOr(bestNormal - t.dir * dot(bestNormal, t.dir), bestNormal);
                // Slightly elliptical lumens at a random orientation (CT
                // airway morphometry: minor/major ~0.9-0.97).
                setFrame(t, t.planeNormal);
                t.eMinor = rotate(t.e1, t.dir, kPi * jitter(rng));
                t.ellipse = 0.065 + 0.035 * jitter(rng);
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
        const Vec3d endDir = normalizeOr(parent.tangent(parent.length), parent.dir);
        const Vec3d lateral = normalizeOr(t.dir - endDir * dot(t.dir, endDir), Vec3d{0, 0, 0});
        t.a = parent.end() + lateral * std::max(0.0, 0.8 * (parent.endRadius - t.radius));
    }
    // The cartilage rings, from a generator of their own (the tree's jitter
    // is unchanged by them).
    std::mt19937_64 ringRng(p.seed * 0x9E3779B97F4A7C15ull + 0x52494E47ull);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (Tube& t : tubes) {
        if (!t.rings) continue;
        const double spacing = kRingSpacing * std::clamp(t.radius / r0, 0.6, 1.0);
        t.ringList.branch = static_cast<int>(&t - tubes.data());
        t.ringList.radius = t.radius;
        t.ringList.halfWidth = 0.55 * spacing;
        t.ringList.heightMm = kRingHeight * t.radius;
        for (double s = spacing * unit(ringRng); s < t.length;) {
            CartilageRing ring;
            ring.s = s;
            ring.height = kRingHeightMin + (1.3 - kRingHeightMin) * unit(ringRng);
            ring.tilt = kRingTiltMm * (2 * unit(ringRng) - 1) * std::clamp(t.radius / r0, 0.3, 1.0);
            ring.tiltAngle = 2 * kPi * unit(ringRng);
            ring.gap = -0.625 + kRingGapJitter * (2 * unit(ringRng) - 1);
            t.ringList.rings.push_back(ring);
            s += spacing * (1 + kRingJitter * (2 * unit(ringRng) - 1));
        }
    }
    return tubes;
}

double smoothstep(double e0, double e1, double x) {
    const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3 - 2 * t);
}

// The axial position of the point of the tube's centre curve nearest to p
// (unclamped): the chord's projection, refined by Gauss-Newton steps on
// |centre(s) - p|^2 for a bent tube (the bends are gentle: two steps converge).
double nearestS(const Tube& t, const Vec3d& p) {
    double s = dot(p - t.a, t.dir);
    if (!t.bent()) return s;
    for (int it = 0; it < 2; ++it) {
        const double sc = std::clamp(s, 0.0, t.length);
        const Vec3d d = t.centre(sc) - p, T = t.tangent(sc);
        s = sc - dot(d, T) / dot(T, T) + (s - sc);
    }
    return s;
}

// Where the surface detail sits on a tube at axial position s, radial unit rn.
struct WallDetail {
    double ring = 0;      // cartilage ridge, 0..1 (profile x C-shape x fade)
    double membrane = 0;  // posterior membranous wall, 0..1 (x fade)
    double fold = 0;      // longitudinal folds there, -1..1 (x membrane)
};

WallDetail wallDetail(const Tube& t, double s, const Vec3d& rn) {
    WallDetail w;
    if (!t.rings) return w;
    const double anterior = dot(rn, t.e1);
    // Fade near both ends: the rings' pattern stops before the junctions.
    const double fade = smoothstep(0, 8, s) * smoothstep(0, 10, t.length - s);
    // The C: cartilage over the anterior and lateral ~270 deg, absent on the
    // posterior membranous wall (-e1), its ends tapering, each ring's gap its own.
    w.ring = t.ringList.ridge(s, std::atan2(dot(rn, t.e2), anterior)) * fade;
    w.membrane = smoothstep(-0.55, -0.85, anterior) * fade;
    // Folds along the airway: a cosine around the wall, each fold wandering
    // slowly sideways along its length.
    const double around = std::atan2(dot(rn, t.e2), -anterior) * t.radius;  // mm from the posterior midline
    const double wobble = 0.6 * std::sin(2 * kPi * s / 37.0);
    w.fold = std::cos(2 * kPi * (around + wobble) / kFoldSpacing) * w.membrane;
    return w;
}

// Signed distance-like field of one tube: < 0 inside its lumen. `sOut`, `rnOut`:
// the axial position (clamped) and radial unit direction there.
double tubeField(const Tube& t, const Vec3d& p, double* sOut = nullptr, Vec3d* rnOut = nullptr) {
    const double along = nearestS(t, p);
    const double s = std::clamp(along, 0.0, t.length);
    const Vec3d c = t.centre(s);
    const Vec3d radial = p - c;
    const double dist = length(radial);
    const Vec3d rn = dist > 1e-9 ? radial * (1 / dist) : t.e1;
    // Taper over the last 1.5 radii towards the children.
    const double taperStart = std::max(0.0, t.length - 1.5 * t.radius);
    double r = t.radius + (t.endRadius - t.radius) * smoothstep(taperStart, t.length, s);
    // Elliptical lumen: shallower along eMinor.
    const double m = dot(rn, t.eMinor);
    r *= 1 - t.ellipse * m * m;
    if (t.rings) {
        const WallDetail w = wallDetail(t, s, rn);
        // The ridges rise into the lumen; the membranous wall is flatter
        // (7 %) and carries its folds.
        r *= 1 - kRingHeight * w.ring;
        r *= 1 - 0.07 * smoothstep(-0.5, -1.0, dot(rn, t.e1)) * smoothstep(0, 8, s) * smoothstep(0, 10, t.length - s);
        r *= 1 - kFoldHeight * 0.5 * (w.membrane + w.fold);
    }
    if (sOut) *sOut = s;
    if (rnOut) *rnOut = rn;
    double d = dist - r;
    // Open end: the children continue it (the end tangent is dir).
    if (!t.leaf) d = std::max(d, dot(p - t.end(), t.dir));
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

    const std::vector<std::uint16_t>* bucket(const Vec3d& p) const {
        const auto ix = static_cast<std::ptrdiff_t>(std::floor((p[0] - lo[0]) / cell));
        const auto iy = static_cast<std::ptrdiff_t>(std::floor((p[1] - lo[1]) / cell));
        const auto iz = static_cast<std::ptrdiff_t>(std::floor((p[2] - lo[2]) / cell));
        if (ix < 0 || iy < 0 || iz < 0 || ix >= std::ptrdiff_t(bx) || iy >= std::ptrdiff_t(by) ||
            iz >= std::ptrdiff_t(bz))
            return nullptr;
        return &buckets[std::size_t(ix) + bx * (std::size_t(iy) + by * std::size_t(iz))];
    }

    // The smooth union of the tubes (parents before children): a flare of
    // kJoinBlend between a tube and the one dominating so far, a crest of
    // kCarinaBlend between siblings. `nearest`: the dominating tube.
    double operator()(const Vec3d& p, int* nearest = nullptr) const {
        const auto* list = bucket(p);
        if (!list) return far;
        double f = far;
        int prev = -1;
        for (std::uint16_t ti : *list) {
            const Tube& t = (*tubes)[ti];
            const double d = tubeField(t, p);
            if (prev < 0) {
                f = d, prev = ti;
                continue;
            }
            const Tube& q = (*tubes)[std::size_t(prev)];
            const bool siblings = t.parent >= 0 && t.parent == q.parent;
            const double k = (siblings ? kCarinaBlend : kJoinBlend) * std::min(t.radius, q.radius);
            if (d < f) prev = ti;
            f = smoothMin(f, d, k);
        }
        if (nearest) *nearest = prev;
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
        // Radius + smooth-union band + the bend off the chord.
        const double reach = std::max(t.radius, t.endRadius) * 1.4 + 2.0 + t.bendReach();
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

// The mucosa's tint (multiplies the albedo): paler and slightly yellow over
// the cartilage rings, where the thin mucosa shows the white hyaline
// cartilage through it, redder and darker on the membranous wall, whose
// submucosa is richer in vessels (the bronchoscopic appearance in Ernst &
// Herth 2013, ch. 6). Values <= 1; "elsewhere" is slightly below 1 in green
// and blue so the rings can be whiter than the rest.
constexpr Vec3d kTintMucosa{1.0, 0.92, 0.90}, kTintCartilage{1.0, 1.0, 0.95}, kTintMembrane{0.93, 0.80, 0.79};

// Hyperaemic patches: real mucosa is patchy within one view, redder areas
// (more blood in the lamina propria) beside paler ones, 3-10 mm across. A
// two-octave solid noise in the wall's own 3D position, so the patches run
// on across branch junctions without the seams of a texture's UV atlas.
// Redness f in -1..1: a red patch (f > 0) loses up to 30 % of its green and
// 15 % of its blue, a pale yellowish one (f < 0) up to 30 % of its blue; the
// hue spread within a frame then comes near the real frames' (docs/theory.md,
// "Airway phantom").
constexpr double kPatchMm = 9.0, kPatchGreen = 0.3, kPatchBlueRed = 0.15, kPatchBlueYellow = 0.3;

Vec3d patchTint(const noise::Permutation& perm, const Vec3d& p) {
    const double e = 0.65 * noise::perlin(perm, p[0] / kPatchMm, p[1] / kPatchMm, p[2] / kPatchMm) +
                     0.35 * noise::perlin(perm, p[0] / (0.4 * kPatchMm) + 17.3, p[1] / (0.4 * kPatchMm) + 5.1,
                                          p[2] / (0.4 * kPatchMm) + 9.7);
    const double f = std::clamp(2.5 * e, -1.0, 1.0);
    if (f >= 0) return {1.0, 1 - kPatchGreen * f, 1 - kPatchBlueRed * f};
    return {1.0, 1.0, 1 + kPatchBlueYellow * f};
}

Vec3d wallTint(const Field& F, const std::vector<Tube>& tubes, const noise::Permutation& perm, const Vec3d& p) {
    const Vec3d patch = patchTint(perm, p);
    auto patched = [&](const Vec3d& c) { return Vec3d{c[0] * patch[0], c[1] * patch[1], c[2] * patch[2]}; };
    int nearest = -1;
    F(p, &nearest);
    if (nearest < 0) return patched(kTintMucosa);
    const Tube& t = tubes[std::size_t(nearest)];
    double s = 0;
    Vec3d rn{};
    tubeField(t, p, &s, &rn);
    const WallDetail w = wallDetail(t, s, rn);
    const Vec3d c = kTintMucosa + (kTintCartilage - kTintMucosa) * std::min(w.ring, 1.0);
    return patched(c + (kTintMembrane - c) * w.membrane);
}

// Moves each vertex of the polygonised surface onto the implicit surface
// (Newton steps along the gradient: p -= f grad / |grad|^2, at most half a
// cell; the projection step of Ohtake & Belyaev 2002): the piecewise-linear
// interpolant marching tetrahedra follows misplaces vertices by up to ~0.1
// mm where the ring profile curves within a cell, and the error follows the
// grid, not the rings: a sawtooth along ridges oblique to the grid. A vertex
// whose move would flip one of its triangles keeps its old place.
template <class Gradient>
void projectOntoSurface(Mesh& mesh, const Field& F, const Gradient& gradient, double h, tbb::task_arena& arena) {
    const std::size_t n = mesh.positions.size();
    std::vector<Vec3> moved(n);
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t v = r.begin(); v != r.end(); ++v) {
                const Vec3d p0 = toD(mesh.positions[v]);
                Vec3d p = p0;
                for (int it = 0; it < 2; ++it) {
                    const Vec3d g = gradient(p);
                    const double gg = dot(g, g);
                    if (!(gg > 1e-12)) break;
                    p = p - g * (F(p) / gg);
                }
                const Vec3d d = p - p0;
                const double len = length(d);
                if (!std::isfinite(len))
                    p = p0;
                else if (len > 0.5 * h)
                    p = p0 + d * (0.5 * h / len);
                moved[v] = toF(p);
            }
        });
    });
    // Keep a vertex in place where its move turns a triangle's normal by more
    // than 60 degrees (or degenerates it); repeat until no triangle is left so.
    std::vector<char> keep(n, 0);
    auto faceNormal = [](const Vec3& a, const Vec3& b, const Vec3& c) {
        return cross(toD(b) - toD(a), toD(c) - toD(a));
    };
    for (bool changed = true; changed;) {  // each pass keeps at least one more vertex: it ends
        changed = false;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            const std::uint32_t i[3] = {mesh.indices[3 * t], mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]};
            auto at = [&](std::uint32_t v) { return keep[v] ? mesh.positions[v] : moved[v]; };
            const Vec3d before = faceNormal(mesh.positions[i[0]], mesh.positions[i[1]], mesh.positions[i[2]]);
            const Vec3d after = faceNormal(at(i[0]), at(i[1]), at(i[2]));
            const double lb = length(before), la = length(after);
            if (la > 1e-6 * lb && dot(before, after) > 0.5 * la * lb) continue;
            for (std::uint32_t v : i)
                if (!keep[v]) keep[v] = 1, changed = true;
        }
    }
    for (std::size_t v = 0; v < n; ++v)
        if (!keep[v]) mesh.positions[v] = moved[v];
}

// On the crest of a carina the field has a crease and its gradient is one
// flank's: where it turns more than 60 deg from the surrounding triangles'
// (area-weighted) normal, that normal is the vertex's. Run on the final
// vertices (after the UV seam's copies), whose triangles are the ones shaded.
void fixCreaseNormals(Mesh& mesh) {
    std::vector<Vec3d> around(mesh.positions.size(), Vec3d{0, 0, 0});
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
        const std::uint32_t* i = &mesh.indices[3 * t];
        const Vec3d a = toD(mesh.positions[i[0]]);
        const Vec3d n = cross(toD(mesh.positions[i[1]]) - a, toD(mesh.positions[i[2]]) - a);
        for (int k = 0; k < 3; ++k) around[i[k]] += n;
    }
    for (std::size_t v = 0; v < around.size(); ++v) {
        const Vec3d w = normalizeOr(around[v], Vec3d{0, 0, 0});
        if (dot(w, w) > 0 && dot(w, toD(mesh.normals[v])) < 0.5) mesh.normals[v] = toF(w);
    }
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
            b.points.push_back(toF(t.centre(s)));
            const double taperStart = std::max(0.0, t.length - 1.5 * t.radius);
            b.radii.push_back(
                static_cast<float>(t.radius + (t.endRadius - t.radius) * smoothstep(taperStart, t.length, s)));
        }
        c.branches.push_back(std::move(b));
    }
    return c;
}

}  // namespace

// Each ring's ridge: a raised cosine halfWidth either side of its (tilted)
// centre, times its height and its C; the highest ring at a point wins, so
// neighbours meet in furrows (the annular ligaments). Broad and smooth (two
// harmonics' worth), so `render`'s 1 cell/mm grid follows it without the
// sawtooth a sharper profile shows.
double TubeRings::ridge(double s, double theta) const {
    const double anterior = std::cos(theta);
    double ring = 0;
    const auto first = std::lower_bound(rings.begin(), rings.end(), s - halfWidth - kRingTiltMm,
                                        [](const CartilageRing& r, double x) { return r.s < x; });
    for (auto it = first; it != rings.end() && it->s < s + halfWidth + kRingTiltMm; ++it) {
        const double x = std::abs(s - (it->s + it->tilt * std::cos(theta - it->tiltAngle)));
        if (x >= halfWidth) continue;
        const double bump = 0.5 + 0.5 * std::cos(kPi * x / halfWidth);
        ring = std::max(ring, it->height * bump * smoothstep(it->gap - 0.175, it->gap + 0.175, anterior));
    }
    return ring;
}

std::vector<TubeRings> phantomRings(const PhantomParams& params) {
    checkParams(params);
    std::vector<TubeRings> out;
    for (Tube& t : buildTree(params))
        if (t.rings) out.push_back(std::move(t.ringList));
    return out;
}

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
                const double r = std::max(t.radius, t.endRadius) + t.bendReach();
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

    report(0.6, "projection");
    const double e = 0.25 * h;
    auto gradient = [&](const Vec3d& p) {
        Vec3d grad;
        for (int k = 0; k < 3; ++k) {
            Vec3d a = p, b = p;
            a[k] += e;
            b[k] -= e;
            grad[k] = (F(a) - F(b)) / (2 * e);
        }
        return grad;
    };
    projectOntoSurface(out.mesh, F, gradient, h, arena);

    report(0.65, "normals");
    // N = -grad f / |grad f| (central differences): towards the lumen.
    out.mesh.normals.resize(out.mesh.positions.size());
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, out.mesh.positions.size(), 1024),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t v = r.begin(); v != r.end(); ++v) {
                                  const Vec3d grad = gradient(toD(out.mesh.positions[v]));
                                  out.mesh.normals[v] = toF(normalizeOr(grad * -1.0, Vec3d{0, 1, 0}));
                              }
                          });
    });
    const noise::Permutation perm = noise::Permutation::fromSeed(params.seed * 0x2545F4914F6CDD1Dull + 0x7A11ull);
    report(0.7, "tint");
    out.mesh.colors.resize(out.mesh.positions.size());
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, out.mesh.positions.size(), 1024),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t v = r.begin(); v != r.end(); ++v)
                                  out.mesh.colors[v] = toF(wallTint(F, tubes, perm, toD(out.mesh.positions[v])));
                          });
    });
    out.centerline = toCenterline(tubes);

    if (params.uvs) {
        report(0.75, "centerline UVs");
        CenterlineUvOptions uo;
        uo.up = {0, 1, 0};
        computeCenterlineUvs(out.mesh, uo);
        fixCreaseNormals(out.mesh);
        report(0.92, "tangents");
        computeTangents(out.mesh, threads);
    } else {
        fixCreaseNormals(out.mesh);
    }
    report(1.0, "done");
    return out;
}

}  // namespace mucosa::mesh
