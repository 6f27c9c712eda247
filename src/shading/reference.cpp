#include <mucosa/shading/reference.hpp>
#include <mucosa/shading/scatter.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/noise/perlin.hpp>

#include <glm/gtc/packing.hpp>

#include "glsl.hpp"

namespace mucosa::shading {

namespace {

using glsl::Varyings;
constexpr int kVaryingFloats = static_cast<int>(sizeof(Varyings) / sizeof(float));
static_assert(sizeof(Varyings) == 28 * sizeof(float), "Varyings must be tightly packed floats");

struct ClipVertex {
    glm::vec4 clip;
    float var[kVaryingFloats];
};

ClipVertex lerp(const ClipVertex& a, const ClipVertex& b, float t) {
    ClipVertex r;
    r.clip = a.clip + (b.clip - a.clip) * t;
    for (int i = 0; i < kVaryingFloats; ++i) r.var[i] = a.var[i] + (b.var[i] - a.var[i]) * t;
    return r;
}

// Sutherland-Hodgman against one clip plane d(v) >= 0 (OpenGL 3.3 core,
// 13.5: -w <= z <= w).
template <class Dist>
std::vector<ClipVertex> clipPolygon(const std::vector<ClipVertex>& in, Dist dist) {
    std::vector<ClipVertex> out;
    const std::size_t n = in.size();
    for (std::size_t i = 0; i < n; ++i) {
        const ClipVertex& a = in[i];
        const ClipVertex& b = in[(i + 1) % n];
        const float da = dist(a.clip), db = dist(b.clip);
        if (da >= 0) out.push_back(a);
        if ((da >= 0) != (db >= 0)) out.push_back(lerp(a, b, da / (da - db)));
    }
    return out;
}

struct Target {
    int width, height;
    std::vector<float> depth;
    std::vector<glm::vec4> color;  // rgb and the specular apart when the frame scatters (else 0)
};

struct ScreenVertex {
    float x, y, z, invW;
    const float* var;
};

// Edge function of (a, b) at p: positive when p is to the left of a->b.
inline float edge(float ax, float ay, float bx, float by, float px, float py) {
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

// OpenGL's top-left rule for pixels exactly on an edge (counter-clockwise
// triangles in window coordinates, y up): a top edge is horizontal with the
// triangle below it, a left edge goes down.
inline bool topLeft(float ax, float ay, float bx, float by) {
    const float dx = bx - ax, dy = by - ay;
    return (dy == 0 && dx < 0) || dy < 0;
}

// Shade(var, dvar/dx, dvar/dy): with `derivatives`, the varyings' screen-space
// derivatives (GLSL dFdx, dFdy) as forward differences of the triangle's
// perspective-correct interpolation one pixel right and one pixel up;
// otherwise both are null.
template <class Shade>
void rasterTriangle(Target& t, ScreenVertex v0, ScreenVertex v1, ScreenVertex v2, bool derivatives, Shade shade) {
    float area = edge(v0.x, v0.y, v1.x, v1.y, v2.x, v2.y);
    if (area == 0 || !std::isfinite(area)) return;
    if (area < 0) {  // no culling: make it counter-clockwise
        std::swap(v1, v2);
        area = -area;
    }
    const float minX = std::min({v0.x, v1.x, v2.x}), maxX = std::max({v0.x, v1.x, v2.x});
    const float minY = std::min({v0.y, v1.y, v2.y}), maxY = std::max({v0.y, v1.y, v2.y});
    const int x0 = std::max(0, static_cast<int>(std::floor(minX - 0.5f)));
    const int x1 = std::min(t.width - 1, static_cast<int>(std::ceil(maxX - 0.5f)));
    const int y0 = std::max(0, static_cast<int>(std::floor(minY - 0.5f)));
    const int y1 = std::min(t.height - 1, static_cast<int>(std::ceil(maxY - 0.5f)));
    const bool tl0 = topLeft(v1.x, v1.y, v2.x, v2.y), tl1 = topLeft(v2.x, v2.y, v0.x, v0.y),
               tl2 = topLeft(v0.x, v0.y, v1.x, v1.y);
    float var[kVaryingFloats], varDx[kVaryingFloats], varDy[kVaryingFloats];
    // Perspective-correct varyings at (px, py), inside the triangle or not.
    const auto interpolate = [&](float px, float py, float* out) {
        const float l0 = edge(v1.x, v1.y, v2.x, v2.y, px, py) / area;
        const float l1 = edge(v2.x, v2.y, v0.x, v0.y, px, py) / area;
        const float l2 = edge(v0.x, v0.y, v1.x, v1.y, px, py) / area;
        const float p0 = l0 * v0.invW, p1 = l1 * v1.invW, p2 = l2 * v2.invW;
        const float s = p0 + p1 + p2;
        for (int i = 0; i < kVaryingFloats; ++i) out[i] = (p0 * v0.var[i] + p1 * v1.var[i] + p2 * v2.var[i]) / s;
    };
    for (int y = y0; y <= y1; ++y) {
        const float py = static_cast<float>(y) + 0.5f;
        for (int x = x0; x <= x1; ++x) {
            const float px = static_cast<float>(x) + 0.5f;
            const float e0 = edge(v1.x, v1.y, v2.x, v2.y, px, py);
            const float e1 = edge(v2.x, v2.y, v0.x, v0.y, px, py);
            const float e2 = edge(v0.x, v0.y, v1.x, v1.y, px, py);
            if (e0 < 0 || e1 < 0 || e2 < 0) continue;
            if ((e0 == 0 && !tl0) || (e1 == 0 && !tl1) || (e2 == 0 && !tl2)) continue;
            const float l0 = e0 / area, l1 = e1 / area, l2 = e2 / area;
            const float z = l0 * v0.z + l1 * v1.z + l2 * v2.z;
            const std::size_t idx = static_cast<std::size_t>(y) * t.width + x;
            if (!(z < t.depth[idx]) || z < 0 || z > 1) continue;
            // Perspective-correct weights (OpenGL 3.3 core, eq. 14.9).
            const float p0 = l0 * v0.invW, p1 = l1 * v1.invW, p2 = l2 * v2.invW;
            const float s = p0 + p1 + p2;
            const float w0 = p0 / s, w1 = p1 / s, w2 = p2 / s;
            for (int i = 0; i < kVaryingFloats; ++i) var[i] = w0 * v0.var[i] + w1 * v1.var[i] + w2 * v2.var[i];
            t.depth[idx] = z;
            if (derivatives) {
                interpolate(px + 1.0f, py, varDx);
                interpolate(px, py + 1.0f, varDy);
                for (int i = 0; i < kVaryingFloats; ++i) varDx[i] -= var[i], varDy[i] -= var[i];
            }
            t.color[idx] = shade(var, derivatives ? varDx : nullptr, derivatives ? varDy : nullptr);
        }
    }
}

std::uint8_t quantize(float c) {
    // OpenGL's float -> unsigned normalised conversion (round to nearest).
    if (!(c > 0.0f)) return 0;
    if (c >= 1.0f) return 255;
    return static_cast<std::uint8_t>(std::floor(c * 255.0f + 0.5f));
}

float texel(const image::Image8& img, int x, int y, int c) {
    // y counts from the bottom row (OpenGL's t = 0) upward.
    const int ch = img.channels() >= 3 ? c : 0;
    return static_cast<float>(img.at(x, img.height() - 1 - y, ch)) / 255.0f;
}

int wrapIndex(int i, int n, Wrap w) {
    if (w == Wrap::Clamp) return std::clamp(i, 0, n - 1);
    const int m = i % n;
    return m < 0 ? m + n : m;
}

// The camera (camera.glsl) on the linear radiance `hdr` (rows bottom-up), as
// the GPU's post pass does it: meter, expose, then per pixel the PSF over
// the 3 x 3 neighbourhood (clamped at the edges) and cameraPixel.
std::vector<glm::vec3> applyCamera(const std::vector<glm::vec3>& hdr, const FrameSetup& frame, ExposureState* state) {
    const int w = frame.width, h = frame.height;
    std::vector<float> grid(3 * static_cast<std::size_t>(kMeterGrid) * kMeterGrid);
    for (int j = 0; j < kMeterGrid; ++j)
        for (int i = 0; i < kMeterGrid; ++i) {
            const glm::vec3& c = hdr[static_cast<std::size_t>(meterPixel(j, h)) * static_cast<std::size_t>(w) +
                                     static_cast<std::size_t>(meterPixel(i, w))];
            float* g = grid.data() + 3 * (static_cast<std::size_t>(j) * kMeterGrid + static_cast<std::size_t>(i));
            // The GPU meters the half-float target.
            g[0] = glm::unpackHalf1x16(glm::packHalf1x16(c.x));
            g[1] = glm::unpackHalf1x16(glm::packHalf1x16(c.y));
            g[2] = glm::unpackHalf1x16(glm::packHalf1x16(c.z));
        }
    ExposureState fresh;
    ExposureState& s = state != nullptr ? *state : fresh;
    const float exposure = exposureFor(frame, meterLuminance(grid.data(), frame), s);
    const std::array<float, 3> veil = veilingGlare(grid.data(), frame);
    const glsl::Camera c = glsl::packCamera(frame, exposure, glm::vec3(veil[0], veil[1], veil[2]));
    std::vector<glm::vec3> out(hdr.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            auto at = [&](int qx, int qy) {
                return hdr[static_cast<std::size_t>(std::clamp(qy, 0, h - 1)) * static_cast<std::size_t>(w) +
                           static_cast<std::size_t>(std::clamp(qx, 0, w - 1))];
            };
            glm::vec3 radiance = at(x, y);
            if (c.softness > 0.0f) {
                // camera_post.frag's loop, tap for tap in the same order.
                glm::vec3 sum(0.0f);
                float weights = 0.0f;
                for (int dy = -glsl::kSoftRadius; dy <= glsl::kSoftRadius; ++dy)
                    for (int dx = -glsl::kSoftRadius; dx <= glsl::kSoftRadius; ++dx) {
                        const float wgt = glsl::psfWeight(dx, dy, c.softness);
                        sum += wgt * at(x + dx, y + dy);
                        weights += wgt;
                    }
                radiance = sum / weights;
            }
            out[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)] =
                glsl::cameraPixel(radiance, x, y, c);
        }
    return out;
}

}  // namespace

std::array<float, 3> sampleTexture(const TextureView& t, float u, float v, std::array<float, 3> fallback) noexcept {
    if (t.image == nullptr || t.image->empty()) return fallback;
    const image::Image8& img = *t.image;
    const int w = img.width(), h = img.height();
    if (t.wrap == Wrap::Clamp) {
        u = std::clamp(u, 0.0f, 1.0f);
        v = std::clamp(v, 0.0f, 1.0f);
    } else {
        u = u - std::floor(u);
        v = v - std::floor(v);
    }
    std::array<float, 3> r{};
    if (t.filter == Filter::Nearest) {
        const int x = wrapIndex(static_cast<int>(std::floor(u * static_cast<float>(w))), w, t.wrap);
        const int y = wrapIndex(static_cast<int>(std::floor(v * static_cast<float>(h))), h, t.wrap);
        for (int c = 0; c < 3; ++c) r[c] = texel(img, x, y, c);
        return r;
    }
    const float fx = u * static_cast<float>(w) - 0.5f, fy = v * static_cast<float>(h) - 0.5f;
    const float ix = std::floor(fx), iy = std::floor(fy);
    const float a = fx - ix, b = fy - iy;
    const int xa = wrapIndex(static_cast<int>(ix), w, t.wrap), xb = wrapIndex(static_cast<int>(ix) + 1, w, t.wrap);
    const int ya = wrapIndex(static_cast<int>(iy), h, t.wrap), yb = wrapIndex(static_cast<int>(iy) + 1, h, t.wrap);
    for (int c = 0; c < 3; ++c)
        r[c] = (1 - a) * (1 - b) * texel(img, xa, ya, c) + a * (1 - b) * texel(img, xb, ya, c) +
               (1 - a) * b * texel(img, xa, yb, c) + a * b * texel(img, xb, yb, c);
    return r;
}

image::Image8 highlightSphereMap(int size, float shininess) {
    MUCOSA_CHECK(size > 0, "highlight texture size must be positive");
    image::Image8 img(size, size, 1);
    for (int row = 0; row < size; ++row) {
        const int j = size - 1 - row;  // t from the bottom
        for (int i = 0; i < size; ++i) {
            // Texel centre -> sphere-map normal n_s -> reflected direction
            // r = (2 n_z n_x, 2 n_z n_y, 2 n_z^2 - 1) of the view ray (0, 0, -1).
            const double x = 2.0 * (i + 0.5) / size - 1.0, y = 2.0 * (j + 0.5) / size - 1.0;
            const double q = x * x + y * y;
            double value = 0.0;
            if (q < 1.0) {
                const double nz = std::sqrt(1.0 - q);
                const double rDotL = 2.0 * nz * nz - 1.0;  // light at the eye: L = (0, 0, 1)
                value = rDotL > 0 ? std::pow(rDotL, static_cast<double>(shininess)) : 0.0;
            }
            img.at(i, row) = static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0, 1.0) * 255.0));
        }
    }
    return img;
}

bool modeNeedsUvs(const FrameSetup& f) noexcept {
    switch (info(f.mode).uvs) {
        case UvNeed::Always:
            return true;
        case UvNeed::InTextureSpace:
            return f.procedural.space == NoiseSpace::Uv;
        case UvNeed::Never:
            return false;
    }
    return true;
}

bool cameraIsIdentity(const ParamSet& p) noexcept {
    return p[Param::AutoExposure] == 0.0f && p[Param::ExposureEv] == 0.0f && p[Param::Vignetting] == 0.0f &&
           p[Param::Mask] == 0.0f && p[Param::Softness] == 0.0f && p[Param::FullWell] == 0.0f &&
           p[Param::ReadNoise] == 0.0f && p[Param::ToneCurve] == 0.0f && p[Param::Saturation] == 1.0f &&
           p[Param::Knee] == 1.0f && p[Param::Flare] == 0.0f;
}

void setCameraIdentity(ParamSet& p) {
    for (Param q : {Param::AutoExposure, Param::ExposureEv, Param::Vignetting, Param::Mask, Param::Softness,
                    Param::FullWell, Param::ReadNoise, Param::ToneCurve, Param::Flare})
        p.set(q, 0.0f);
    p.set(Param::Saturation, 1.0f);
    p.set(Param::Knee, 1.0f);
}

int meterPixel(int i, int size) noexcept {
    return std::min(size - 1, static_cast<int>(std::floor((static_cast<float>(i) + 0.5f) * static_cast<float>(size) /
                                                          static_cast<float>(kMeterGrid))));
}

float meterLuminance(const float* rgb, const FrameSetup& frame) {
    const glsl::Camera c = glsl::packCamera(frame, 1.0f);
    double sum = 0.0, weights = 0.0;
    std::vector<float> inside;  // the luminance of the points inside the mask
    inside.reserve(static_cast<std::size_t>(kMeterGrid) * kMeterGrid);
    for (int j = 0; j < kMeterGrid; ++j)
        for (int i = 0; i < kMeterGrid; ++i) {
            const float* p = rgb + 3 * (static_cast<std::size_t>(j) * kMeterGrid + static_cast<std::size_t>(i));
            const float px = static_cast<float>(meterPixel(i, frame.width)) + 0.5f;
            const float py = static_cast<float>(meterPixel(j, frame.height)) + 0.5f;
            const float w = glsl::fovMask(px, py, c);
            const float y = 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
            const float seen = y * glsl::vignetting(px, py, c);
            sum += static_cast<double>(w * seen);
            weights += static_cast<double>(w);
            if (w >= 0.5f) inside.push_back(seen);
        }
    if (weights <= 0.0 || inside.empty()) return 0.0f;
    // Peak-weighted: the near wall, brightest, must not clip.
    const auto k = static_cast<std::ptrdiff_t>(0.95 * static_cast<double>(inside.size() - 1));
    std::nth_element(inside.begin(), inside.begin() + k, inside.end());
    const float peak = inside[static_cast<std::size_t>(k)];
    const float w = frame.params[Param::AutoPeak];
    return (1.0f - w) * static_cast<float>(sum / weights) + w * peak;
}

std::array<float, 3> veilingGlare(const float* rgb, const FrameSetup& frame) {
    const float flare = frame.params[Param::Flare];
    if (flare <= 0.0f) return {0.0f, 0.0f, 0.0f};
    const glsl::Camera c = glsl::packCamera(frame, 1.0f);
    glm::dvec3 sum(0.0);
    double weights = 0.0;
    for (int j = 0; j < kMeterGrid; ++j)
        for (int i = 0; i < kMeterGrid; ++i) {
            const float* p = rgb + 3 * (static_cast<std::size_t>(j) * kMeterGrid + static_cast<std::size_t>(i));
            const float px = static_cast<float>(meterPixel(i, frame.width)) + 0.5f;
            const float py = static_cast<float>(meterPixel(j, frame.height)) + 0.5f;
            const double w = glsl::fovMask(px, py, c);
            sum += w * static_cast<double>(glsl::vignetting(px, py, c)) * glm::dvec3(p[0], p[1], p[2]);
            weights += w;
        }
    if (weights <= 0.0) return {0.0f, 0.0f, 0.0f};
    const glm::dvec3 veil = static_cast<double>(flare) * sum / weights;
    return {static_cast<float>(veil.x), static_cast<float>(veil.y), static_cast<float>(veil.z)};
}

float toneCurve(float signal, int curve) noexcept {
    return glsl::toneCurve(signal, curve);
}

float kneeCurve(float value, float knee) noexcept {
    return glsl::kneeCurve(value, knee);
}

float inverseKneeCurve(float value, float knee) noexcept {
    return glsl::inverseKneeCurve(value, knee);
}

float inverseToneCurve(float value, int curve) noexcept {
    return glsl::inverseToneCurve(value, curve);
}

float exposureFor(const FrameSetup& frame, float metered, ExposureState& state) {
    if (frame.fixedExposure > 0.0f) return frame.fixedExposure;
    const ParamSet& p = frame.params;
    if (p[Param::AutoExposure] == 0.0f) {
        state = {true, p[Param::ExposureEv]};
        return std::exp2(state.ev);
    }
    // Aim: metered x 2^EV = key (plus the compensation exposure_ev). A black
    // frame (nothing lit in view) keeps the last exposure instead of
    // diverging: the gain of a real camera has a ceiling.
    const float floor = 1e-8f;
    const float target = std::log2(p[Param::AutoKey] / std::max(metered, floor)) + p[Param::ExposureEv];
    if (frame.frameIndex == 0 || frame.restartExposure || !state.primed) {
        state = {true, target};
    } else {
        // First-order lag with time constant tau, sampled at the frame rate.
        const float tau = p[Param::Adaptation];
        const float dt = 1.0f / p[Param::FrameRate];
        const float k = tau > 0.0f ? 1.0f - std::exp(-dt / tau) : 1.0f;
        state.ev += k * (target - state.ev);
    }
    return std::exp2(state.ev);
}

image::Image8 renderReference(const mesh::Mesh& mesh, const FrameSetup& frame, const Textures& textures,
                              ExposureState* exposure) {
    if (!mesh.hasNormals()) throw InputError("mesh", "", "the reference renderer needs vertex normals");
    if (modeNeedsUvs(frame) && (!mesh.hasUvs() || !mesh.hasTangents()))
        throw InputError(
            "mode", "",
            fmt::format("'{}' needs texture coordinates and tangents, which the mesh lacks", modeName(frame.mode)));
    const glsl::Material m = glsl::packMaterial(frame.params);
    const glsl::Frame f = glsl::packFrame(frame);
    const glsl::Procedural pr = glsl::packProcedural(frame);
    const noise::Permutation perm = noise::Permutation::fromSeed(frame.procedural.noise.seed);
    const glsl::PermutationScope permScope(perm.table().data());
    const int mode = static_cast<int>(frame.mode);
    const bool photographic = info(frame.mode).photographic;
    const bool scatter = scattersLight(frame);
    const bool develop = photographic && (!cameraIsIdentity(frame.params) || scatter);
    const bool derivatives = glsl::modeIsProcedural(mode) && frame.specularAA;

    std::vector<ClipVertex> verts(mesh.vertexCount());
    for (std::size_t i = 0; i < verts.size(); ++i) {
        const auto& p = mesh.positions[i];
        const auto& n = mesh.normals[i];
        const auto& tg = mesh.hasTangents() ? mesh.tangents[i] : mesh::fallbackTangent(n);
        const mesh::Vec2 uv = mesh.hasUvs() ? mesh.uvs[i] : mesh::Vec2{0, 0};
        const glm::vec3 P(p[0], p[1], p[2]);
        const mesh::Vec3 tint = mesh.hasColors() ? mesh.colors[i] : mesh::Vec3{1, 1, 1};
        const Varyings v =
            glsl::tissueVertex(P, glm::vec3(n[0], n[1], n[2]), glm::vec4(tg[0], tg[1], tg[2], tg[3]),
                               glm::vec2(uv[0], uv[1]), glm::vec3(tint[0], tint[1], tint[2]), f, m, mode);
        verts[i].clip = glsl::tissueClipPosition(P, f);
        std::memcpy(verts[i].var, &v, sizeof v);
    }

    Target t{frame.width, frame.height, std::vector<float>(static_cast<std::size_t>(frame.width) * frame.height, 1.0f),
             std::vector<glm::vec4>(static_cast<std::size_t>(frame.width) * frame.height, glm::vec4(0.0f))};
    const float W = static_cast<float>(frame.width), H = static_cast<float>(frame.height);
    if (develop && frame.params[Param::Mask] != 0.0f) {
        // The GPU's occluder outside the scope's mask (camera_mask.frag): the
        // near plane's depth there, so nothing is drawn, and the scattering's
        // taps there fall back to their centre, as on the GPU.
        glsl::Camera grown = glsl::packCamera(frame, 1.0f);
        grown.maskRadius += glsl::kMaskMarginPx / (0.5f * std::min(W, H));
        for (int y = 0; y < frame.height; ++y)
            for (int x = 0; x < frame.width; ++x)
                if (glsl::fovMask(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, grown) <= 0.0f)
                    t.depth[static_cast<std::size_t>(y) * frame.width + x] = 0.0f;
    }

    auto shade = [&](const float* var, const float* varDx, const float* varDy) {
        Varyings v;
        std::memcpy(&v, var, sizeof v);
        float footprint = 0.0f;
        if (varDx != nullptr) {
            float ax[kVaryingFloats], ay[kVaryingFloats];
            for (int i = 0; i < kVaryingFloats; ++i) ax[i] = var[i] + varDx[i], ay[i] = var[i] + varDy[i];
            Varyings vx, vy;
            std::memcpy(&vx, ax, sizeof vx);
            std::memcpy(&vy, ay, sizeof vy);
            const glm::vec3 q = glsl::proceduralCoord(v, m, pr);
            footprint =
                glsl::noiseFootprint(glsl::proceduralCoord(vx, m, pr) - q, glsl::proceduralCoord(vy, m, pr) - q);
        }
        std::array<float, 3> albedo{1, 1, 1}, map{0.5f, 0.5f, 1.0f};
        float highlight = 0.0f;
        if (glsl::modeReadsDiffuse(mode)) {
            const glm::vec2 dc = glsl::diffuseCoord(v.uv, f);
            albedo = sampleTexture(textures.diffuse, dc.x, dc.y, {1, 1, 1});
        }
        if (glsl::modeReadsReflectanceMap(mode)) {
            const glm::vec2 mc = glsl::reflectanceMapCoord(v.uv, m);
            map = sampleTexture(textures.reflectance, mc.x, mc.y, {0.5f, 0.5f, 1.0f});
        }
        if (glsl::modeReadsHighlight(mode))
            highlight = sampleTexture(textures.highlight, v.sphereUv.x, v.sphereUv.y, {0, 0, 0})[0];
        // Level 0 only: its slope deviation (alpha) is 0 (reflectance::specularMipChain).
        const glm::vec4 parts =
            glsl::tissueFragmentParts(v, glm::vec3(albedo[0], albedo[1], albedo[2]),
                                      glm::vec4(map[0], map[1], map[2], 0.0f), highlight, footprint, m, pr, f, mode);
        // Linear radiance for the camera (kept in the range of the GPU's
        // half-float target), apart for the scattering, or display values.
        if (scatter) return glm::clamp(parts, 0.0f, glsl::kHalfMax);
        const glm::vec3 c = glm::vec3(parts) + glm::vec3(parts.w);
        return glm::vec4(develop ? glm::clamp(c, 0.0f, glsl::kHalfMax) : glm::clamp(c, 0.0f, 1.0f), 0.0f);
    };

    for (std::size_t tri = 0; tri + 2 < mesh.indices.size(); tri += 3) {
        std::vector<ClipVertex> poly = {verts[mesh.indices[tri]], verts[mesh.indices[tri + 1]],
                                        verts[mesh.indices[tri + 2]]};
        const auto inside = [](const ClipVertex& c) { return c.clip.z >= -c.clip.w && c.clip.z <= c.clip.w; };
        if (!(inside(poly[0]) && inside(poly[1]) && inside(poly[2]))) {
            poly = clipPolygon(poly, [](const glm::vec4& c) { return c.z + c.w; });
            if (poly.size() >= 3) poly = clipPolygon(poly, [](const glm::vec4& c) { return c.w - c.z; });
            if (poly.size() < 3) continue;
        }
        std::vector<ScreenVertex> sv(poly.size());
        for (std::size_t i = 0; i < poly.size(); ++i) {
            const glm::vec4& c = poly[i].clip;
            const float invW = 1.0f / c.w;
            sv[i] = {(c.x * invW * 0.5f + 0.5f) * W, (c.y * invW * 0.5f + 0.5f) * H, c.z * invW * 0.5f + 0.5f, invW,
                     poly[i].var};
        }
        for (std::size_t i = 1; i + 1 < sv.size(); ++i) rasterTriangle(t, sv[0], sv[i], sv[i + 1], derivatives, shade);
    }

    std::vector<glm::vec3> color(t.color.size());
    if (scatter) {
        std::vector<float> parts(4 * t.color.size());
        for (std::size_t i = 0; i < t.color.size(); ++i)
            for (int c = 0; c < 4; ++c) parts[4 * i + c] = t.color[i][c];
        const std::vector<float> rgb =
            applyScatter(parts, t.depth, frame.width, frame.height, frame.projection,
                         scatterKernel(frame.params.color(Param::Scatter)), frame.params[Param::ScatterShare]);
        for (std::size_t i = 0; i < color.size(); ++i) color[i] = glm::vec3(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
    } else {
        for (std::size_t i = 0; i < color.size(); ++i) color[i] = glm::vec3(t.color[i]);
    }
    if (develop) color = applyCamera(color, frame, exposure);
    image::Image8 out(frame.width, frame.height, 3);
    for (int y = 0; y < frame.height; ++y)
        for (int x = 0; x < frame.width; ++x) {
            const glm::vec3& c = color[static_cast<std::size_t>(y) * frame.width + x];
            const int row = frame.height - 1 - y;  // OpenGL's y is up; files are top-down
            out.at(x, row, 0) = quantize(c.x);
            out.at(x, row, 1) = quantize(c.y);
            out.at(x, row, 2) = quantize(c.z);
        }
    return out;
}

}  // namespace mucosa::shading
