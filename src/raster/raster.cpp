#include <mucosa/raster/raster.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/memory.hpp>
#include <mucosa/core/parallel.hpp>

namespace mucosa::raster {

namespace {

struct ClipVertex {
    double x, y, z;  // camera space
    double b1, b2;   // barycentrics w.r.t. the original triangle
};

ClipVertex mix(const ClipVertex& a, const ClipVertex& b, double t) {
    return {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z), a.b1 + t * (b.b1 - a.b1),
            a.b2 + t * (b.b2 - a.b2)};
}

// Sutherland-Hodgman against z >= near: at most 4 vertices out.
int clipNear(const ClipVertex in[3], double near, ClipVertex out[4]) {
    int n = 0;
    for (int i = 0; i < 3; ++i) {
        const ClipVertex& a = in[i];
        const ClipVertex& b = in[(i + 1) % 3];
        const bool ain = a.z >= near, bin = b.z >= near;
        if (ain) out[n++] = a;
        if (ain != bin) out[n++] = mix(a, b, (near - a.z) / (b.z - a.z));
    }
    return n;
}

struct ScreenVertex {
    double sx, sy, invz, b1z, b2z;  // attributes divided by z for perspective correction
};

void rasterTriangle(const ScreenVertex& v0, const ScreenVertex& v1, const ScreenVertex& v2, std::int32_t tri,
                    int yBegin, int yEnd, GBuffer& g) {
    const double area = (v1.sx - v0.sx) * (v2.sy - v0.sy) - (v2.sx - v0.sx) * (v1.sy - v0.sy);
    if (std::fabs(area) < 1e-12) return;
    const double minX = std::min({v0.sx, v1.sx, v2.sx}), maxX = std::max({v0.sx, v1.sx, v2.sx});
    const double minY = std::min({v0.sy, v1.sy, v2.sy}), maxY = std::max({v0.sy, v1.sy, v2.sy});
    const int x0 = std::max(0, static_cast<int>(std::ceil(minX)));
    const int x1 = std::min(g.width - 1, static_cast<int>(std::floor(maxX)));
    const int y0 = std::max(yBegin, static_cast<int>(std::ceil(minY)));
    const int y1 = std::min(yEnd - 1, static_cast<int>(std::floor(maxY)));
    if (x0 > x1 || y0 > y1) return;
    const double inv = 1.0 / area;
    for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) {
            // Edge functions at the pixel centre (x, y).
            const double l1 = ((x - v0.sx) * (v2.sy - v0.sy) - (v2.sx - v0.sx) * (y - v0.sy)) * inv;
            const double l2 = ((v1.sx - v0.sx) * (y - v0.sy) - (x - v0.sx) * (v1.sy - v0.sy)) * inv;
            const double l0 = 1.0 - l1 - l2;
            if (l0 < 0 || l1 < 0 || l2 < 0) continue;
            const double invz = l0 * v0.invz + l1 * v1.invz + l2 * v2.invz;
            if (invz <= 0) continue;
            const double z = 1.0 / invz;
            const std::size_t i = static_cast<std::size_t>(y) * g.width + x;
            if (z >= g.depth[i]) continue;
            g.depth[i] = static_cast<float>(z);
            g.triangle[i] = tri;
            g.b1[i] = static_cast<float>((l0 * v0.b1z + l1 * v1.b1z + l2 * v2.b1z) * z);
            g.b2[i] = static_cast<float>((l0 * v0.b2z + l1 * v1.b2z + l2 * v2.b2z) * z);
        }
    }
}

}  // namespace

std::size_t GBuffer::hits() const noexcept {
    return static_cast<std::size_t>(std::count_if(triangle.begin(), triangle.end(), [](auto t) { return t >= 0; }));
}

namespace {

// A triangle clipped against the near plane and projected: one polygon of 3
// or 4 corners (two triangles when the plane cuts it).
struct Projected {
    ScreenVertex s[4];
    int corners = 0;
    int yMin = 0, yMax = -1;  // rows its bounding box spans, inside the image
};

// Which of the view volume's planes a camera-space point lies outside of:
// behind the near plane, or more than a pixel past an edge of the image
// (sx < -1, sx > width, sy < -1, sy > height, written as half-spaces so they
// hold for points behind the camera too). A triangle whose three corners are
// all outside one plane lies wholly outside it, so no point of it projects
// into the image: the clip-and-project below would refuse it, and the
// pixel's margin keeps that true through rounding.
constexpr std::uint8_t kBehind = 1;

std::uint8_t outcode(const frames::Vec3d& v, const frames::Intrinsics& K, double near) {
    const double x = v[0], y = v[1], z = v[2];
    std::uint8_t c = 0;
    if (z < near) c |= kBehind;
    if (!(K.fx > 0 && K.fy > 0)) return c;  // the side planes as written assume the usual axes
    if (K.fx * x + (K.cx + 1) * z < 0) c |= 2;
    if (K.fx * x + (K.cx - K.width) * z > 0) c |= 4;
    if (K.fy * y + (K.cy + 1) * z < 0) c |= 8;
    if (K.fy * y + (K.cy - K.height) * z > 0) c |= 16;
    return c;
}

// The mesh's vertices seen from the camera, once per pass: camera space,
// outcode, and (in front of the near plane) the projection, which the ~6
// triangles sharing a vertex then read instead of each dividing again.
struct Screen {
    double sx, sy, invz;
};
struct Vertices {
    std::vector<frames::Vec3d> cam;
    std::vector<std::uint8_t> code;
    std::vector<Screen> screen;

    explicit Vertices(std::size_t n) : cam(n), code(n), screen(n) {}
    void set(std::size_t i, const frames::Vec3d& c, const frames::Intrinsics& K, double near) {
        cam[i] = c;
        code[i] = outcode(c, K, near);
        if (code[i] & kBehind) return;
        const double iz = 1.0 / c[2];
        screen[i] = {K.fx * c[0] * iz + K.cx, K.fy * c[1] * iz + K.cy, iz};
    }
};
constexpr std::size_t kBytesPerVertex = sizeof(frames::Vec3d) + 1 + sizeof(Screen);

// False when the triangle is wholly outside the view or its bounding box holds
// no pixel centre of the image. A triangle with no corner behind the near
// plane takes its corners' projections as they are (the same numbers the
// clip would give: it copies such corners unchanged); one that straddles the
// plane is clipped first.
bool project(const Vertices& vs, const mesh::Mesh& mesh, std::size_t t, const frames::Intrinsics& K, double near,
             Projected& u) {
    const std::uint32_t* idx = &mesh.indices[3 * t];
    const std::uint8_t c0 = vs.code[idx[0]], c1 = vs.code[idx[1]], c2 = vs.code[idx[2]];
    if (c0 & c1 & c2) return false;
    int m = 3;
    if (((c0 | c1 | c2) & kBehind) == 0) {
        for (int k = 0; k < 3; ++k) {
            const Screen& p = vs.screen[idx[k]];
            u.s[k] = {p.sx, p.sy, p.invz, k == 1 ? p.invz : 0.0, k == 2 ? p.invz : 0.0};
        }
    } else {
        ClipVertex in[3];
        for (int k = 0; k < 3; ++k) {
            const frames::Vec3d& v = vs.cam[idx[k]];
            in[k] = {v[0], v[1], v[2], k == 1 ? 1.0 : 0.0, k == 2 ? 1.0 : 0.0};
        }
        ClipVertex poly[4];
        m = clipNear(in, near, poly);
        if (m < 3) return false;
        for (int k = 0; k < m; ++k) {
            const double iz = 1.0 / poly[k].z;
            u.s[k] = {K.fx * poly[k].x * iz + K.cx, K.fy * poly[k].y * iz + K.cy, iz, poly[k].b1 * iz, poly[k].b2 * iz};
        }
    }
    double minX = u.s[0].sx, maxX = minX, minY = u.s[0].sy, maxY = minY;
    for (int k = 1; k < m; ++k) {
        minX = std::min(minX, u.s[k].sx), maxX = std::max(maxX, u.s[k].sx);
        minY = std::min(minY, u.s[k].sy), maxY = std::max(maxY, u.s[k].sy);
    }
    if (!(maxX >= 0 && minX <= K.width - 1 && maxY >= 0 && minY <= K.height - 1)) return false;
    // No pixel centre inside the box: most triangles of a fine mesh on a
    // coarse level of the registration's pyramid. (Clamped to the image
    // before the conversion: a projection near the near plane can be huge.)
    if (std::ceil(std::max(minX, 0.0)) > std::floor(std::min(maxX, K.width - 1.0))) return false;
    u.corners = m;
    u.yMin = static_cast<int>(std::ceil(std::max(minY, 0.0)));
    u.yMax = static_cast<int>(std::floor(std::min(maxY, K.height - 1.0)));
    return u.yMin <= u.yMax;
}

void rasterProjected(const Projected& u, std::int32_t tri, int yBegin, int yEnd, GBuffer& g) {
    rasterTriangle(u.s[0], u.s[1], u.s[2], tri, yBegin, yEnd, g);
    if (u.corners == 4) rasterTriangle(u.s[0], u.s[2], u.s[3], tri, yBegin, yEnd, g);
}

}  // namespace

GBuffer rasterize(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& W, double near,
                  int threads) {
    GBuffer g;
    g.width = K.width;
    g.height = K.height;
    const std::size_t n = static_cast<std::size_t>(K.width) * K.height;
    // A kept triangle: its index and the rows it spans.
    struct Kept {
        std::int32_t tri;
        int yMin, yMax;
    };
    const std::size_t triangles = mesh.triangleCount();
    const int workers = resolveThreads(threads);
    // The z-buffer, the vertices in camera space, the kept triangles.
    requireMemory(saturatingMul(n, 16) + saturatingMul(mesh.vertexCount(), kBytesPerVertex) +
                      (workers == 1 ? 0 : saturatingMul(triangles, sizeof(Kept))),
                  "a depth pass");
    g.triangle.assign(n, -1);
    g.b1.assign(n, 0.f);
    g.b2.assign(n, 0.f);
    g.depth.assign(n, std::numeric_limits<float>::infinity());

    Vertices vs(mesh.vertexCount());
    const auto toCamera = [&](std::size_t i) {
        const auto& p = mesh.positions[i];
        vs.set(i, frames::transformPoint(W, {p[0], p[1], p[2]}), K, near);
    };
    if (workers == 1) {
        // One pass, nothing stored: the registration calls this thousands of
        // times on small images from inside its own parallel loops.
        for (std::size_t i = 0; i < mesh.vertexCount(); ++i) toCamera(i);
        Projected u;
        for (std::size_t t = 0; t < triangles; ++t)
            if (project(vs, mesh, t, K, near, u)) rasterProjected(u, static_cast<std::int32_t>(t), 0, K.height, g);
        return g;
    }
    // Each triangle is culled once (in chunks of triangles, in parallel) and
    // kept, with its rows, only where its bounding box meets the image; then
    // bands of rows rasterise, each owning its rows of the z-buffer, taking
    // the kept triangles that reach its rows in the mesh's order and
    // projecting them again (cheaper than storing the projection, and a
    // triangle reaches one or two bands), so the result is the same, bit for
    // bit, for any number of threads. (Every band clipping and projecting
    // every triangle cost 8x that work on two cores.)
    constexpr std::size_t kChunk = 16384;
    const std::size_t chunks = (triangles + kChunk - 1) / kChunk;
    std::vector<std::vector<Kept>> kept(chunks);
    tbb::task_arena arena(workers);
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.vertexCount(), 4096), [&](const auto& r) {
            for (std::size_t i = r.begin(); i < r.end(); ++i) toCamera(i);
        });
        tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
            std::vector<Kept>& out = kept[c];
            const std::size_t end = std::min(triangles, (c + 1) * kChunk);
            Projected u;
            for (std::size_t t = c * kChunk; t < end; ++t)
                if (project(vs, mesh, t, K, near, u)) out.push_back({static_cast<std::int32_t>(t), u.yMin, u.yMax});
        });
        const int bands = std::max(1, std::min(K.height, 4 * workers));
        tbb::parallel_for(0, bands, [&](int band) {
            const int yBegin = K.height * band / bands, yEnd = K.height * (band + 1) / bands;
            Projected u;
            for (const std::vector<Kept>& chunk : kept)
                for (const Kept& k : chunk) {
                    if (k.yMax < yBegin || k.yMin >= yEnd) continue;
                    project(vs, mesh, static_cast<std::size_t>(k.tri), K, near, u);
                    rasterProjected(u, k.tri, yBegin, yEnd, g);
                }
        });
    });
    return g;
}

}  // namespace mucosa::raster
