#include <mucosa/fit/raster.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/memory.hpp>
#include <mucosa/core/parallel.hpp>

namespace mucosa::fit {

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

GBuffer rasterize(const mesh::Mesh& mesh, const Intrinsics& K, const Mat4& W, double near, int threads) {
    GBuffer g;
    g.width = K.width;
    g.height = K.height;
    const std::size_t n = static_cast<std::size_t>(K.width) * K.height;
    // A triangle clipped and projected once.
    struct Setup {
        ScreenVertex s[4];
        std::int32_t tri;
        int corners;     // 3, or 4 (clipped by the near plane: two triangles)
        int yMin, yMax;  // rows its bounding box spans, inside the image
    };
    // The z-buffer, the vertices in camera space, each triangle's set-up.
    requireMemory(saturatingMul(n, 16) + saturatingMul(mesh.vertexCount(), 24) +
                      saturatingMul(mesh.triangleCount(), sizeof(Setup)),
                  "a depth pass");
    g.triangle.assign(n, -1);
    g.b1.assign(n, 0.f);
    g.b2.assign(n, 0.f);
    g.depth.assign(n, std::numeric_limits<float>::infinity());

    std::vector<Vec3d> cam(mesh.vertexCount());
    const std::size_t triangles = mesh.triangleCount();
    const int workers = resolveThreads(threads);
    // Each triangle is clipped and projected once (in chunks of triangles, in
    // parallel), kept only where its bounding box meets the image; then
    // bands of rows rasterise, each owning its rows of the z-buffer and
    // taking the kept triangles in the mesh's order, so the result is the
    // same for any number of threads. (Every band setting up every triangle
    // cost 8x the setup on two cores.)
    constexpr std::size_t kChunk = 4096;
    const std::size_t chunks = (triangles + kChunk - 1) / kChunk;
    std::vector<std::vector<Setup>> kept(chunks);
    tbb::task_arena arena(workers);
    arena.execute([&] {
        tbb::parallel_for(std::size_t{0}, cam.size(), [&](std::size_t i) {
            const auto& p = mesh.positions[i];
            cam[i] = transformPoint(W, {p[0], p[1], p[2]});
        });
        tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
            std::vector<Setup>& out = kept[c];
            for (std::size_t t = c * kChunk; t < std::min(triangles, (c + 1) * kChunk); ++t) {
                ClipVertex in[3];
                for (int k = 0; k < 3; ++k) {
                    const Vec3d& v = cam[mesh.indices[3 * t + k]];
                    in[k] = {v[0], v[1], v[2], k == 1 ? 1.0 : 0.0, k == 2 ? 1.0 : 0.0};
                }
                if (in[0].z < near && in[1].z < near && in[2].z < near) continue;
                ClipVertex poly[4];
                const int m = clipNear(in, near, poly);
                if (m < 3) continue;
                Setup u;
                double minX = std::numeric_limits<double>::infinity(), maxX = -minX, minY = minX, maxY = -minX;
                for (int k = 0; k < m; ++k) {
                    const double iz = 1.0 / poly[k].z;
                    u.s[k] = {K.fx * poly[k].x * iz + K.cx, K.fy * poly[k].y * iz + K.cy, iz, poly[k].b1 * iz,
                              poly[k].b2 * iz};
                    minX = std::min(minX, u.s[k].sx), maxX = std::max(maxX, u.s[k].sx);
                    minY = std::min(minY, u.s[k].sy), maxY = std::max(maxY, u.s[k].sy);
                }
                // No pixel centre inside the image (or a degenerate projection).
                if (!(maxX >= 0 && minX <= K.width - 1 && maxY >= 0 && minY <= K.height - 1)) continue;
                u.tri = static_cast<std::int32_t>(t);
                u.corners = m;
                // Clamped to the image before the conversion (a projection near the near plane can be huge).
                u.yMin = static_cast<int>(std::ceil(std::max(minY, 0.0)));
                u.yMax = static_cast<int>(std::floor(std::min(maxY, K.height - 1.0)));
                if (u.yMin > u.yMax) continue;
                out.push_back(u);
            }
        });
        const int bands = workers == 1 ? 1 : std::max(1, std::min(K.height, 4 * workers));
        tbb::parallel_for(0, bands, [&](int band) {
            const int yBegin = K.height * band / bands, yEnd = K.height * (band + 1) / bands;
            for (const std::vector<Setup>& chunk : kept)
                for (const Setup& u : chunk) {
                    if (u.yMax < yBegin || u.yMin >= yEnd) continue;
                    rasterTriangle(u.s[0], u.s[1], u.s[2], u.tri, yBegin, yEnd, g);
                    if (u.corners == 4) rasterTriangle(u.s[0], u.s[2], u.s[3], u.tri, yBegin, yEnd, g);
                }
        });
    });
    return g;
}

}  // namespace mucosa::fit
