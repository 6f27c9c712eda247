#include <mucosa/camera/camera.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <fmt/format.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <mucosa/core/error.hpp>

namespace mucosa::camera {

namespace {

glm::vec3 v(const Vec3& a) {
    return {a[0], a[1], a[2]};
}
Vec3 a3(const glm::vec3& x) {
    return {x.x, x.y, x.z};
}

Mat4 toArray(const glm::mat4& m) {
    Mat4 r{};
    for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) r[static_cast<std::size_t>(c * 4 + row)] = m[c][row];
    return r;
}

// Orthonormal right/up/forward of a pose; a degenerate up is replaced.
void basis(const Pose& p, glm::vec3& right, glm::vec3& up, glm::vec3& forward) {
    forward = glm::normalize(v(p.forward));
    glm::vec3 u = v(p.up);
    glm::vec3 r = glm::cross(forward, u);
    if (glm::length(r) < 1e-6f) {
        u = std::abs(forward.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
        r = glm::cross(forward, u);
    }
    right = glm::normalize(r);
    up = glm::cross(right, forward);
}

}  // namespace

void validate(const Lens& lens) {
    if (!(lens.fovDeg > 1.0f && lens.fovDeg < 179.0f))
        throw InputError("camera.fov_deg", "", fmt::format("{} is out of range (1, 179)", lens.fovDeg));
    if (!(lens.nearMm > 0.0f) || !std::isfinite(lens.nearMm))
        throw InputError("camera.near_mm", "", "must be a positive number");
    if (!(lens.farMm > lens.nearMm) || !std::isfinite(lens.farMm))
        throw InputError("camera.far_mm", "", "must be larger than near_mm");
}

Mat4 viewMatrix(const Pose& pose) {
    glm::vec3 r, u, f;
    basis(pose, r, u, f);
    const glm::vec3 e = v(pose.position);
    return toArray(glm::lookAt(e, e + f, u));
}

Mat4 projectionMatrix(const Lens& lens, int width, int height) {
    const float aspect = static_cast<float>(width) / static_cast<float>(height);
    const float half = glm::radians(lens.fovDeg) * 0.5f;
    // The field of view spans the larger dimension.
    const float fovY = aspect >= 1.0f ? 2.0f * std::atan(std::tan(half) / aspect) : 2.0f * half;
    return toArray(glm::perspective(fovY, aspect, lens.nearMm, lens.farMm));
}

Vec3 lightPosition(const Pose& pose, const TipLight& light) {
    glm::vec3 r, u, f;
    basis(pose, r, u, f);
    return a3(v(pose.position) + light.offset[0] * r + light.offset[1] * u + light.offset[2] * f);
}

Pose lookAt(const Vec3& eye, const Vec3& target, const Vec3& up) {
    Pose p;
    p.position = eye;
    p.forward = a3(glm::normalize(v(target) - v(eye)));
    p.up = up;
    return p;
}

std::vector<Pose> interpolatePoses(const std::vector<Pose>& keys, int frames) {
    if (keys.empty()) throw InputError("camera.path.poses", "", "needs at least one pose");
    if (frames < 1) throw InputError("frames", "", "must be at least 1");
    std::vector<Pose> out;
    const int n = static_cast<int>(keys.size());
    for (int i = 0; i < frames; ++i) {
        if (n == 1) {
            out.push_back(keys[0]);
            continue;
        }
        const float s =
            frames == 1 ? 0.0f : static_cast<float>(i) * static_cast<float>(n - 1) / static_cast<float>(frames - 1);
        const int k = std::min(static_cast<int>(s), n - 2);
        const float t = s - static_cast<float>(k);
        const auto at = [&](int j) { return v(keys[static_cast<std::size_t>(std::clamp(j, 0, n - 1))].position); };
        // Catmull-Rom 1974 through the key positions.
        const glm::vec3 p0 = at(k - 1), p1 = at(k), p2 = at(k + 1), p3 = at(k + 2);
        const float t2 = t * t, t3 = t2 * t;
        const glm::vec3 p = 0.5f * ((2.0f * p1) + (-p0 + p2) * t + (2.0f * p0 - 5.0f * p1 + 4.0f * p2 - p3) * t2 +
                                    (-p0 + 3.0f * p1 - 3.0f * p2 + p3) * t3);
        glm::vec3 r1, u1, f1, r2, u2, f2;
        basis(keys[static_cast<std::size_t>(k)], r1, u1, f1);
        basis(keys[static_cast<std::size_t>(k + 1)], r2, u2, f2);
        Pose pose;
        pose.position = a3(p);
        glm::vec3 f = glm::mix(f1, f2, t);
        if (glm::length(f) < 1e-6f) f = f2;
        pose.forward = a3(glm::normalize(f));
        pose.up = a3(glm::mix(u1, u2, t));
        out.push_back(pose);
    }
    return out;
}

float pathLength(const std::vector<Vec3>& polyline) {
    float len = 0.0f;
    for (std::size_t i = 1; i < polyline.size(); ++i) len += glm::length(v(polyline[i]) - v(polyline[i - 1]));
    return len;
}

namespace {

// A smooth seeded signal in [-1, 1] along the path: three sinusoids of
// incommensurate periods between `minPeriod` and 2.3 x `minPeriod`, weights
// summing to 1 (a band-limited random walk; |d/ds| <= 2 pi / minPeriod).
struct Wave {
    float weight[3], k[3], phase[3];
    Wave(std::mt19937_64& rng, float minPeriod) {
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        const float w[3] = {0.5f, 0.3f, 0.2f};
        for (int i = 0; i < 3; ++i) {
            weight[i] = w[i];
            const float period = minPeriod * (2.3f - 0.6f * static_cast<float>(i)) * (0.85f + 0.15f * u(rng));
            k[i] = 2.0f * std::numbers::pi_v<float> / std::max(period, minPeriod);
            phase[i] = 2.0f * std::numbers::pi_v<float> * u(rng);
        }
    }
    float operator()(float s) const {
        float v = 0.0f;
        for (int i = 0; i < 3; ++i) v += weight[i] * std::sin(k[i] * s + phase[i]);
        return v;
    }
};

glm::vec3 rotateAbout(const glm::vec3& x, const glm::vec3& axis, float angle) {
    // Rodrigues' rotation formula.
    const float c = std::cos(angle), s = std::sin(angle);
    return x * c + glm::cross(axis, x) * s + axis * (glm::dot(axis, x) * (1.0f - c));
}

// The up vector carried along a path of view directions without twist: at
// the first frame made orthogonal to f (any up if parallel), then
// parallel-transported (double reflection, Wang et al. 2008, simplified to
// one rotation): rotated by the rotation taking prevForward to f.
glm::vec3 transportUp(glm::vec3 up, const glm::vec3& prevForward, const glm::vec3& f, bool first) {
    if (first) {
        glm::vec3 r = glm::cross(f, up);
        if (glm::length(r) < 1e-6f) r = glm::cross(f, std::abs(f.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0));
        return glm::normalize(glm::cross(glm::normalize(r), f));
    }
    const glm::vec3 axis = glm::cross(prevForward, f);
    const float sinA = glm::length(axis), cosA = glm::dot(prevForward, f);
    if (sinA > 1e-7f) {
        const glm::vec3 k = axis / sinA;
        up = up * cosA + glm::cross(k, up) * sinA + k * glm::dot(k, up) * (1.0f - cosA);
    }
    return glm::normalize(up - f * glm::dot(up, f));
}

// The view turned (the tip's bending section): yaw about up, then pitch about
// the turned right axis; up turns with it.
void turnView(glm::vec3& forward, glm::vec3& poseUp, const glm::vec3& up, const glm::vec3& right, float yaw,
              float pitch) {
    forward = rotateAbout(forward, up, yaw);
    const glm::vec3 r2 = rotateAbout(right, up, yaw);
    forward = glm::normalize(rotateAbout(forward, r2, pitch));
    poseUp = glm::normalize(rotateAbout(up, r2, pitch));
}

}  // namespace

void validate(const FlyThrough& o) {
    if (!(o.wander >= 0.0f && o.wander <= 0.9f))
        throw InputError("camera.path.wander", "", fmt::format("{} is outside 0..0.9", o.wander));
    if (!(o.lookAroundDeg >= 0.0f && o.lookAroundDeg <= 60.0f))
        throw InputError("camera.path.look_around_deg", "", fmt::format("{} is outside 0..60", o.lookAroundDeg));
    if (!(o.wallClearanceMm >= 0.0f) || !std::isfinite(o.wallClearanceMm))
        throw InputError("camera.path.wall_clearance_mm", "", "must be a number >= 0");
    if (!(o.wanderPeriodMm >= 1.0f) || !std::isfinite(o.wanderPeriodMm))
        throw InputError("camera.path.wander_period_mm", "", "must be a number >= 1");
}

std::vector<Pose> flyThrough(const std::vector<Vec3>& centerline, const FlyThrough& o,
                             const std::vector<float>& radii) {
    if (o.frames < 1) throw InputError("frames", "", "must be at least 1");
    validate(o);
    const bool haveRadii = !radii.empty() && radii.size() == centerline.size();
    // Drop repeated points; keep the cumulative arc length (and each kept point's radius).
    std::vector<glm::vec3> pts;
    std::vector<float> arc, rad;
    for (std::size_t i = 0; i < centerline.size(); ++i) {
        const glm::vec3 q = v(centerline[i]);
        if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
            throw InputError("camera.path", "", "centerline has a non-finite point");
        if (!pts.empty() && glm::length(q - pts.back()) < 1e-6f) continue;
        arc.push_back(pts.empty() ? 0.0f : arc.back() + glm::length(q - pts.back()));
        pts.push_back(q);
        if (haveRadii) {
            const float r = radii[i];
            if (!std::isfinite(r) || r < 0.0f) throw InputError("camera.path", "", "centerline has a bad radius");
            rad.push_back(r);
        }
    }
    if (pts.size() < 2) throw InputError("camera.path", "", "centerline needs at least two distinct points");
    const float total = arc.back();
    // Segment k and the fraction along it at arc length s.
    const auto locate = [&](float s, float& t) {
        s = std::clamp(s, 0.0f, total);
        const auto it = std::upper_bound(arc.begin(), arc.end(), s);
        const std::size_t k = std::min<std::size_t>(
            static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - arc.begin(), 1)) - 1, pts.size() - 2);
        t = std::clamp((s - arc[k]) / std::max(arc[k + 1] - arc[k], 1e-6f), 0.0f, 1.0f);
        return k;
    };
    const auto at = [&](float s) {
        float t;
        const std::size_t k = locate(s, t);
        return glm::mix(pts[k], pts[k + 1], t);
    };
    // The lumen radius the offset must respect: the smallest within 6 mm
    // either way (continuous in s, and ahead of narrowings and of the jumps
    // at branch points).
    const auto radiusNear = [&](float s) {
        float r = 1e30f;
        for (int j = -6; j <= 6; ++j) {
            float t;
            const std::size_t k = locate(s + static_cast<float>(j), t);
            r = std::min(r, rad[k] + (rad[k + 1] - rad[k]) * t);
        }
        return r;
    };
    const bool offsets = o.wander > 0.0f && haveRadii;
    const bool turns = o.lookAroundDeg > 0.0f;
    std::mt19937_64 rng(o.seed);
    const Wave offsetX(rng, o.wanderPeriodMm), offsetY(rng, o.wanderPeriodMm), yawWave(rng, o.wanderPeriodMm),
        pitchWave(rng, o.wanderPeriodMm);
    const float maxTurn = o.lookAroundDeg * std::numbers::pi_v<float> / 180.0f;

    const float start = std::clamp(o.startMm, 0.0f, total);
    const float end = std::max(start, total - std::max(o.stopMm, 0.0f));
    const float step =
        o.speedMm > 0.0f ? o.speedMm : (o.frames > 1 ? (end - start) / static_cast<float>(o.frames - 1) : 0.0f);
    const float ahead = std::max(o.lookAheadMm, 1e-3f);
    std::vector<Pose> out;
    glm::vec3 up = v(o.up);
    glm::vec3 prevForward(0.0f);
    for (int i = 0; i < o.frames; ++i) {
        const float s = std::min(start + step * static_cast<float>(i), end);
        glm::vec3 p = at(s);
        // Look at a point ahead on the line; near the end, keep the last direction.
        glm::vec3 f = at(s + ahead) - p;
        if (glm::length(f) < 1e-3f * ahead) f = p - at(s - ahead);
        f = glm::normalize(f);
        up = transportUp(up, prevForward, f, i == 0);
        prevForward = f;
        glm::vec3 forward = f, poseUp = up;
        const glm::vec3 right = glm::normalize(glm::cross(f, up));
        if (offsets) {
            // Off the centre in the plane across the path: within a disc of
            // radius min(wander R, R - clearance) (|(x, y)| / sqrt 2 <= 1).
            const float R = radiusNear(s);
            const float reach = std::max(0.0f, std::min(o.wander * R, R - o.wallClearanceMm));
            const float k = reach * 0.70710678f;
            p += right * (k * offsetX(s)) + up * (k * offsetY(s));
        }
        if (turns) {
            turnView(forward, poseUp, up, right, maxTurn * yawWave(s), maxTurn * pitchWave(s));
        }
        Pose pose;
        pose.position = a3(p);
        pose.forward = a3(forward);
        pose.up = a3(poseUp);
        out.push_back(pose);
    }
    return out;
}

}  // namespace mucosa::camera

namespace mucosa::camera {

namespace {

// A root-to-leaf path of the tree with its arc length and radii.
struct Route {
    std::vector<glm::vec3> pts;
    std::vector<float> arc, rad;
    std::vector<int> branchEnds;  // arc index where each branch of the chain ends (the carinas)
    float length() const { return arc.back(); }
    std::size_t locate(float s, float& t) const {
        s = std::clamp(s, 0.0f, length());
        const auto it = std::upper_bound(arc.begin(), arc.end(), s);
        const std::size_t k = std::min<std::size_t>(
            static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - arc.begin(), 1)) - 1, pts.size() - 2);
        t = std::clamp((s - arc[k]) / std::max(arc[k + 1] - arc[k], 1e-6f), 0.0f, 1.0f);
        return k;
    }
    glm::vec3 at(float s) const {
        float t;
        const std::size_t k = locate(s, t);
        return glm::mix(pts[k], pts[k + 1], t);
    }
    float radius(float s) const {
        float t;
        const std::size_t k = locate(s, t);
        return rad[k] + (rad[k + 1] - rad[k]) * t;
    }
    // The smallest radius within 6 mm either way (ahead of narrowings).
    float radiusNear(float s) const {
        float r = 1e30f;
        for (int j = -6; j <= 6; ++j) r = std::min(r, radius(s + static_cast<float>(j)));
        return r;
    }
    // The distal direction at s: towards the point `ahead` further on.
    glm::vec3 direction(float s, float ahead) const {
        glm::vec3 f = at(s + ahead) - at(s);
        if (glm::length(f) < 1e-3f * ahead) f = at(s) - at(s - ahead);
        return glm::normalize(f);
    }
};

Route routeTo(const mesh::Centerline& c, int leaf) {
    std::vector<int> chain;
    for (int b = leaf; b >= 0; b = c.branches[static_cast<std::size_t>(b)].parent) chain.push_back(b);
    Route r;
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
        const mesh::CenterlineBranch& br = c.branches[static_cast<std::size_t>(*it)];
        for (std::size_t i = 0; i < br.points.size(); ++i) {
            const glm::vec3 q = v(br.points[i]);
            if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
                throw InputError("camera.path", "", "centerline has a non-finite point");
            const float rad = i < br.radii.size() ? br.radii[i] : 0.0f;
            if (!std::isfinite(rad) || rad < 0.0f) throw InputError("camera.path", "", "centerline has a bad radius");
            if (!r.pts.empty() && glm::length(q - r.pts.back()) < 1e-6f) continue;
            r.arc.push_back(r.pts.empty() ? 0.0f : r.arc.back() + glm::length(q - r.pts.back()));
            r.pts.push_back(q);
            r.rad.push_back(rad);
        }
        r.branchEnds.push_back(static_cast<int>(r.pts.size()) - 1);
    }
    return r;
}

// One leg of the survey on route `route`: from arc s0 to s1 over `duration`
// (mm of advance), the view blending from route `viewFrom`'s distal
// direction to `route`'s (a pause at a carina turning to the next orifice).
struct Leg {
    int route = 0, viewFrom = 0;
    float s0 = 0, s1 = 0, duration = 0;
};

}  // namespace

void validate(const Survey& o) {
    if (!(o.rollDeg >= 0.0f && o.rollDeg <= 90.0f))
        throw InputError("camera.path.roll_deg", "", fmt::format("{} is outside 0..90", o.rollDeg));
    if (!(o.pauseMm >= 0.0f) || !std::isfinite(o.pauseMm))
        throw InputError("camera.path.pause_mm", "", "must be a number >= 0");
    if (!(o.withdrawSpeed >= 1.0f) || !std::isfinite(o.withdrawSpeed))
        throw InputError("camera.path.withdraw_speed", "", "must be a number >= 1");
    if (!(o.carinaBackoff >= 0.0f) || !std::isfinite(o.carinaBackoff))
        throw InputError("camera.path.carina_backoff", "", "must be a number >= 0");
}

// The survey stops this many radii (plus stopMm) before a leaf's distal end:
// a bronchoscope stops where the bronchus gets too narrow for it, looking
// into its dark continuation rather than at the cap that ends a model.
constexpr float kLeafStopRadii = 3.0f;

std::vector<Pose> surveyTree(const mesh::Centerline& tree, const FlyThrough& o, const Survey& sv, float stopMm) {
    if (o.frames < 1) throw InputError("frames", "", "must be at least 1");
    validate(o);
    validate(sv);
    if (tree.branches.empty()) throw InputError("camera.path.centerline", "", "the centerline has no branches");
    const std::size_t n = tree.branches.size();
    // Leaves in depth-first order (children in their order in the file).
    std::vector<std::vector<int>> children(n);
    for (std::size_t b = 0; b < n; ++b) {
        const int p = tree.branches[b].parent;
        if (p >= static_cast<int>(b))
            throw InputError("camera.path.centerline", "", "parents must come before children");
        if (p >= 0) children[static_cast<std::size_t>(p)].push_back(static_cast<int>(b));
    }
    std::vector<int> leaves, stack;
    for (std::size_t b = n; b-- > 0;)
        if (tree.branches[b].parent < 0) stack.push_back(static_cast<int>(b));
    while (!stack.empty()) {
        const int b = stack.back();
        stack.pop_back();
        const auto& ch = children[static_cast<std::size_t>(b)];
        if (ch.empty()) leaves.push_back(b);
        for (auto it = ch.rbegin(); it != ch.rend(); ++it) stack.push_back(*it);
    }
    std::vector<Route> routes;
    std::vector<int> routeLeaf;
    for (int leaf : leaves) {
        Route r = routeTo(tree, leaf);
        if (r.pts.size() < 2) continue;
        const mesh::CenterlineBranch& br = tree.branches[static_cast<std::size_t>(leaf)];
        const float own = camera::pathLength(br.points);
        const float radius = br.radii.empty() ? 0.0f : br.radii.back();
        if (routes.size() > 0 && own < radius) continue;  // a stub: nothing to enter
        routes.push_back(std::move(r));
        routeLeaf.push_back(leaf);
    }
    if (routes.empty()) throw InputError("camera.path", "", "centerline needs at least two distinct points");
    const float start = std::clamp(o.startMm, 0.0f, routes.front().length());
    auto stopOf = [&](std::size_t k) {
        const Route& r = routes[k];
        return std::max(start, r.length() - std::max(stopMm + kLeafStopRadii * r.rad.back(), 0.0f));
    };
    // The legs: advance into the first leaf, pause; then for each next leaf:
    // withdraw to just above the carina it shares with the previous one,
    // pause turning, advance, pause.
    std::vector<Leg> legs;
    const float withdraw = sv.withdrawSpeed;
    legs.push_back({0, 0, start, stopOf(0), stopOf(0) - start});
    legs.push_back({0, 0, stopOf(0), stopOf(0), sv.pauseMm});
    for (std::size_t k = 1; k < routes.size(); ++k) {
        const Route& a = routes[k - 1];
        const Route& b = routes[k];
        // The common prefix: the last carina both chains pass.
        std::size_t common = 0;
        {
            std::vector<int> ca, cb;
            for (int x = routeLeaf[k - 1]; x >= 0; x = tree.branches[static_cast<std::size_t>(x)].parent)
                ca.push_back(x);
            for (int x = routeLeaf[k]; x >= 0; x = tree.branches[static_cast<std::size_t>(x)].parent) cb.push_back(x);
            std::reverse(ca.begin(), ca.end());
            std::reverse(cb.begin(), cb.end());
            while (common < ca.size() && common < cb.size() && ca[common] == cb[common]) ++common;
        }
        const std::size_t endIndex = static_cast<std::size_t>(b.branchEnds[std::max<std::size_t>(common, 1) - 1]);
        const float carina = b.arc[std::min(endIndex, b.arc.size() - 1)];
        const float above = std::max(start, carina - sv.carinaBackoff * b.radius(carina));
        const float from = legs.back().s1;
        legs.push_back({static_cast<int>(k - 1), static_cast<int>(k - 1), from, std::min(above, from),
                        std::abs(from - std::min(above, from)) / withdraw});
        const float at = legs.back().s1;
        legs.push_back({static_cast<int>(k), static_cast<int>(k - 1), at, at, sv.pauseMm});
        const float stop = std::max(at, stopOf(k));
        legs.push_back({static_cast<int>(k), static_cast<int>(k), at, stop, stop - at});
        legs.push_back({static_cast<int>(k), static_cast<int>(k), stop, stop, sv.pauseMm});
        (void)a;
    }
    legs.pop_back();  // no pause after the last leaf: the survey ends there
    std::vector<float> legStart{0.0f};
    for (const Leg& l : legs) legStart.push_back(legStart.back() + l.duration);
    const float total = legStart.back();

    std::mt19937_64 rng(o.seed);
    const float period = o.wanderPeriodMm;
    const Wave offsetX(rng, period), offsetY(rng, period), yawWave(rng, period), pitchWave(rng, period),
        rollWave(rng, 1.5f * period);
    constexpr float kDeg = std::numbers::pi_v<float> / 180.0f;
    const float maxTurn = o.lookAroundDeg * kDeg, maxRoll = sv.rollDeg * kDeg;
    const float ahead = std::max(o.lookAheadMm, 1e-3f);
    const float step = o.speedMm > 0.0f ? o.speedMm : (o.frames > 1 ? total / static_cast<float>(o.frames - 1) : 0.0f);

    std::vector<Pose> out;
    glm::vec3 up = v(o.up), prevForward(0.0f);
    for (int i = 0; i < o.frames; ++i) {
        const float tau = std::min(step * static_cast<float>(i), total);
        const std::size_t li = std::min<std::size_t>(
            static_cast<std::size_t>(std::upper_bound(legStart.begin(), legStart.end(), tau) - legStart.begin()) - 1,
            legs.size() - 1);
        const Leg& leg = legs[li];
        const float u = leg.duration > 0 ? std::clamp((tau - legStart[li]) / leg.duration, 0.0f, 1.0f) : 1.0f;
        // Easing in and out of every move: the scope starts and stops gently.
        const float e = u * u * (3.0f - 2.0f * u);
        const float s = leg.s0 + (leg.s1 - leg.s0) * e;
        const Route& r = routes[static_cast<std::size_t>(leg.route)];
        glm::vec3 p = r.at(s);
        glm::vec3 f = r.direction(s, ahead);
        if (leg.viewFrom != leg.route) {
            const glm::vec3 f0 = routes[static_cast<std::size_t>(leg.viewFrom)].direction(s, ahead);
            const glm::vec3 m = glm::mix(f0, f, e);
            f = glm::length(m) > 1e-4f ? glm::normalize(m) : f;
        }
        up = transportUp(up, prevForward, f, i == 0);
        prevForward = f;
        const glm::vec3 right = glm::normalize(glm::cross(f, up));
        // Off the centre, within a disc of radius min(wander R, R - clearance).
        if (o.wander > 0.0f) {
            const float R = r.radiusNear(s);
            const float reach = std::max(0.0f, std::min(o.wander * R, R - o.wallClearanceMm));
            const float k = reach * 0.70710678f;
            p += right * (k * offsetX(tau)) + up * (k * offsetY(tau));
        }
        glm::vec3 forward = f, poseUp = up;
        if (maxTurn > 0.0f) {
            turnView(forward, poseUp, up, right, maxTurn * yawWave(tau), maxTurn * pitchWave(tau));
        }
        if (maxRoll > 0.0f) poseUp = glm::normalize(rotateAbout(poseUp, forward, maxRoll * rollWave(tau)));
        Pose pose;
        pose.position = a3(p);
        pose.forward = a3(forward);
        pose.up = a3(poseUp);
        out.push_back(pose);
    }
    return out;
}

}  // namespace mucosa::camera
