// A small CPU rasteriser for the README's pictures of meshes (no GPU needed):
// an outside view and an endoscope-like view from inside, side by side.
//   mesh_picture OUT.png [MESH]   (default: the built-in phantom)
// Outside: Lambert shading; inside: a headlight at the camera with 1/d^2
// falloff and a faint checker of the mesh's UVs (to show the parameterisation).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <mucosa/image/png.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/phantom.hpp>

namespace {

using namespace mucosa;
using mesh::Vec3;

struct V3 {
    double x, y, z;
};
V3 operator-(V3 a, V3 b) {
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V3 operator+(V3 a, V3 b) {
    return {a.x + b.x, a.y + b.y, a.z + b.z};
}
V3 operator*(V3 a, double s) {
    return {a.x * s, a.y * s, a.z * s};
}
double dot(V3 a, V3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
V3 cross(V3 a, V3 b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
V3 norm(V3 a) {
    return a * (1.0 / std::sqrt(dot(a, a)));
}
V3 v3(const Vec3& a) {
    return {a[0], a[1], a[2]};
}

struct Camera {
    V3 eye, fwd, right, up;
    double focal;  // in pixels
    int w, h;
};

Camera lookAt(V3 eye, V3 target, V3 upHint, double fovDeg, int w, int h) {
    Camera c;
    c.eye = eye;
    c.fwd = norm(target - eye);
    c.right = norm(cross(c.fwd, upHint));
    c.up = cross(c.right, c.fwd);
    c.focal = 0.5 * w / std::tan(0.5 * fovDeg * M_PI / 180);
    c.w = w;
    c.h = h;
    return c;
}

// Renders into rgb (w*h*3 floats), z-buffered, perspective-correct attributes.
void render(const mesh::Mesh& m, const Camera& c, bool inside, std::vector<float>& rgb) {
    const int W = c.w, H = c.h;
    std::vector<double> zbuf(std::size_t(W) * H, 1e300);
    rgb.assign(std::size_t(W) * H * 3, inside ? 0.0f : 1.0f);
    std::vector<V3> cam(m.vertexCount());
    for (std::size_t v = 0; v < m.vertexCount(); ++v) {
        const V3 d = v3(m.positions[v]) - c.eye;
        cam[v] = {dot(d, c.right), dot(d, c.up), dot(d, c.fwd)};
    }
    const V3 tissue{0.85, 0.42, 0.40};
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        const std::uint32_t i[3] = {m.indices[3 * t], m.indices[3 * t + 1], m.indices[3 * t + 2]};
        double sx[3], sy[3], iz[3];
        bool ok = true;
        for (int k = 0; k < 3; ++k) {
            const V3 p = cam[i[k]];
            if (p.z < 0.5) ok = false;
            iz[k] = 1.0 / p.z;
            sx[k] = 0.5 * W + c.focal * p.x * iz[k];
            sy[k] = 0.5 * H - c.focal * p.y * iz[k];
        }
        if (!ok) continue;
        const double area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
        if (std::abs(area) < 1e-12) continue;
        const int x0 = std::max(0, int(std::floor(std::min({sx[0], sx[1], sx[2]})))),
                  x1 = std::min(W - 1, int(std::ceil(std::max({sx[0], sx[1], sx[2]}))));
        const int y0 = std::max(0, int(std::floor(std::min({sy[0], sy[1], sy[2]})))),
                  y1 = std::min(H - 1, int(std::ceil(std::max({sy[0], sy[1], sy[2]}))));
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x) {
                const double px = x + 0.5, py = y + 0.5;
                double b[3];
                for (int k = 0; k < 3; ++k) {
                    const int a1 = (k + 1) % 3, a2 = (k + 2) % 3;
                    b[k] = ((sx[a2] - sx[a1]) * (py - sy[a1]) - (sy[a2] - sy[a1]) * (px - sx[a1])) / area;
                }
                if (b[0] < 0 || b[1] < 0 || b[2] < 0) continue;
                const double izp = b[0] * iz[0] + b[1] * iz[1] + b[2] * iz[2];
                const double z = 1.0 / izp;
                double& zb = zbuf[std::size_t(y) * W + x];
                if (z >= zb) continue;
                zb = z;
                double wgt[3];
                for (int k = 0; k < 3; ++k) wgt[k] = b[k] * iz[k] * z;
                V3 N{0, 0, 0};
                for (int k = 0; k < 3; ++k) N = N + v3(m.normals[i[k]]) * wgt[k];
                N = norm(N);
                V3 P{0, 0, 0};
                for (int k = 0; k < 3; ++k) P = P + v3(m.positions[i[k]]) * wgt[k];
                const V3 L = norm(c.eye - P);
                V3 col;
                if (inside) {
                    const double d = std::sqrt(dot(c.eye - P, c.eye - P));
                    const double ndl = std::max(0.0, dot(N, L));
                    const double fall = 1.0 / (1.0 + (d / 22.0) * (d / 22.0));
                    double check = 1.0;
                    if (m.hasUvs()) {
                        double u = 0, v = 0;
                        for (int k = 0; k < 3; ++k) u += m.uvs[i[k]][0] * wgt[k], v += m.uvs[i[k]][1] * wgt[k];
                        check = ((int(std::floor(u * 8)) + int(std::floor(v * 8))) & 1) ? 1.0 : 0.86;
                    }
                    const double spec = std::pow(std::max(0.0, dot(N, L)), 60) * 0.5;
                    col = tissue * (ndl * fall * 1.1 * check) + V3{1, 1, 1} * (spec * fall * 1.1);
                } else {
                    const V3 key = norm(V3{0.4, 0.6, 1.0});
                    const double ndl = std::abs(dot(N, key)) * 0.75 + std::abs(dot(N, L)) * 0.25;
                    col = tissue * (0.25 + 0.75 * ndl);
                }
                float* o = &rgb[(std::size_t(y) * W + x) * 3];
                o[0] = float(col.x), o[1] = float(col.y), o[2] = float(col.z);
            }
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: mesh_picture OUT.png [MESH]\n");
        return 2;
    }
    try {
        const mesh::Mesh m = argc > 2 ? mesh::load(argv[2]) : mesh::makePhantom(mesh::PhantomParams{}).mesh;
        V3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
        for (const Vec3& p : m.positions)
            lo = {std::min(lo.x, double(p[0])), std::min(lo.y, double(p[1])), std::min(lo.z, double(p[2]))},
            hi = {std::max(hi.x, double(p[0])), std::max(hi.y, double(p[1])), std::max(hi.z, double(p[2]))};
        const V3 centre = (lo + hi) * 0.5;
        const int S = 2, W = 640, H = 800;  // 2x2 supersampling
        const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
        // Outside, from the front (anterior, +Z), slightly from the right.
        const Camera outside =
            lookAt(centre + V3{0.25 * extent, 0.1 * extent, 2.2 * extent}, centre, {0, 1, 0}, 28, W * S, H * S);
        // Inside the trachea, 80 mm below its top, looking down at the carina
        // (anterior up, as bronchoscopists hold the scope).
        const Camera inside = lookAt({0, -80, 2}, {0, -120, -1}, {0, 0, 1}, 100, W * S, H * S);
        std::vector<float> a, b;
        render(m, outside, false, a);
        render(m, inside, true, b);
        image::Image8 img(2 * W, H, 3);
        auto put = [&](const std::vector<float>& src, int xOff) {
            for (int y = 0; y < H; ++y)
                for (int x = 0; x < W; ++x)
                    for (int ch = 0; ch < 3; ++ch) {
                        double s = 0;
                        for (int dy = 0; dy < S; ++dy)
                            for (int dx = 0; dx < S; ++dx)
                                s += src[((std::size_t(y) * S + dy) * W * S + (x * S + dx)) * 3 + ch];
                        s /= S * S;
                        img.at(x + xOff, y, ch) =
                            static_cast<std::uint8_t>(std::clamp(std::pow(s, 1 / 2.2) * 255.0 + 0.5, 0.0, 255.0));
                    }
        };
        put(a, 0);
        put(b, W);
        image::writePng(argv[1], img);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
