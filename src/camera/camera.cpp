#include <mucosa/camera/camera.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

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

std::vector<Pose> flyThrough(const std::vector<Vec3>& centerline, const FlyThrough& o) {
    if (o.frames < 1) throw InputError("frames", "", "must be at least 1");
    // Drop repeated points; keep the cumulative arc length.
    std::vector<glm::vec3> pts;
    std::vector<float> arc;
    for (const Vec3& p : centerline) {
        const glm::vec3 q = v(p);
        if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
            throw InputError("camera.path", "", "centerline has a non-finite point");
        if (!pts.empty() && glm::length(q - pts.back()) < 1e-6f) continue;
        arc.push_back(pts.empty() ? 0.0f : arc.back() + glm::length(q - pts.back()));
        pts.push_back(q);
    }
    if (pts.size() < 2) throw InputError("camera.path", "", "centerline needs at least two distinct points");
    const float total = arc.back();
    const auto at = [&](float s) {
        s = std::clamp(s, 0.0f, total);
        const auto it = std::upper_bound(arc.begin(), arc.end(), s);
        const std::size_t k = std::min<std::size_t>(
            static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - arc.begin(), 1)) - 1, pts.size() - 2);
        const float t = (s - arc[k]) / std::max(arc[k + 1] - arc[k], 1e-6f);
        return glm::mix(pts[k], pts[k + 1], std::clamp(t, 0.0f, 1.0f));
    };
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
        const glm::vec3 p = at(s);
        // Look at a point ahead on the line; near the end, keep the last direction.
        glm::vec3 f = at(s + ahead) - p;
        if (glm::length(f) < 1e-3f * ahead) f = p - at(s - ahead);
        f = glm::normalize(f);
        if (i == 0) {
            glm::vec3 r = glm::cross(f, up);
            if (glm::length(r) < 1e-6f)
                r = glm::cross(f, std::abs(f.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0));
            up = glm::normalize(glm::cross(glm::normalize(r), f));
        } else {
            // Parallel transport (double reflection, Wang et al. 2008, simplified
            // to one rotation): rotate `up` by the rotation taking prevForward to f.
            const glm::vec3 axis = glm::cross(prevForward, f);
            const float sinA = glm::length(axis), cosA = glm::dot(prevForward, f);
            if (sinA > 1e-7f) {
                const glm::vec3 k = axis / sinA;
                up = up * cosA + glm::cross(k, up) * sinA + k * glm::dot(k, up) * (1.0f - cosA);
            }
            up = glm::normalize(up - f * glm::dot(up, f));
        }
        prevForward = f;
        Pose pose;
        pose.position = a3(p);
        pose.forward = a3(f);
        pose.up = a3(up);
        out.push_back(pose);
    }
    return out;
}

}  // namespace mucosa::camera
