#include <mucosa/render/primitives.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <span>

#include <mucosa/core/error.hpp>
#include <mucosa/noise/fractal.hpp>

namespace mucosa::render {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;

void gridIndices(mesh::Mesh& m, int cols, int rows) {
    // (cols + 1) x (rows + 1) vertices, counter-clockwise seen from the normal side.
    for (int j = 0; j < rows; ++j)
        for (int i = 0; i < cols; ++i) {
            const auto a = static_cast<std::uint32_t>(j * (cols + 1) + i), b = a + 1,
                       c = a + static_cast<std::uint32_t>(cols + 1), d = c + 1;
            m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
        }
}

// Tube centreline: straight for the first third, then an arc bending towards +x.
void tubeFrame(float length, float s, mesh::Vec3& c, mesh::Vec3& t) {
    const float straight = length / 3.0f, bendRadius = length;
    if (s <= straight) {
        c = {0.0f, 0.0f, -s};
        t = {0.0f, 0.0f, -1.0f};
        return;
    }
    const float phi = (s - straight) / bendRadius;
    c = {bendRadius * (1.0f - std::cos(phi)), 0.0f, -straight - bendRadius * std::sin(phi)};
    t = {std::sin(phi), 0.0f, -std::cos(phi)};
}

}  // namespace

mesh::Mesh makeQuad(float size, int n, bool mirrorU) {
    MUCOSA_CHECK(n >= 1, "quad needs at least one cell");
    mesh::Mesh m;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const float s = static_cast<float>(i) / static_cast<float>(n),
                        t = static_cast<float>(j) / static_cast<float>(n);
            m.positions.push_back({(s - 0.5f) * size, (t - 0.5f) * size, 0.0f});
            m.normals.push_back({0.0f, 0.0f, 1.0f});
            m.uvs.push_back({mirrorU ? 1.0f - s : s, t});
            // dP/du = -x when mirrored; B = w cross(N, T) must stay +y (dP/dv).
            m.tangents.push_back(mirrorU ? mesh::Vec4{-1.0f, 0.0f, 0.0f, -1.0f} : mesh::Vec4{1.0f, 0.0f, 0.0f, 1.0f});
        }
    gridIndices(m, n, n);
    return m;
}

mesh::Mesh makeSphere(float radius, int slices, int stacks) {
    MUCOSA_CHECK(slices >= 3 && stacks >= 2, "sphere needs 3 slices and 2 stacks");
    mesh::Mesh m;
    for (int j = 0; j <= stacks; ++j) {
        const float v = static_cast<float>(j) / static_cast<float>(stacks), theta = kPi * (v - 0.5f);  // latitude
        for (int i = 0; i <= slices; ++i) {
            const float u = static_cast<float>(i) / static_cast<float>(slices), phi = 2.0f * kPi * u;
            const mesh::Vec3 n{std::cos(theta) * std::cos(phi), std::cos(theta) * std::sin(phi), std::sin(theta)};
            m.positions.push_back({radius * n[0], radius * n[1], radius * n[2]});
            m.normals.push_back(n);
            m.uvs.push_back({u, v});
            // dP/du along the parallel (defined at the poles too); B = cross(N, T) = dP/dv (north).
            m.tangents.push_back({-std::sin(phi), std::cos(phi), 0.0f, 1.0f});
        }
    }
    gridIndices(m, slices, stacks);
    return m;
}

mesh::Mesh makeTube(float radius, float length, int around, int along) {
    MUCOSA_CHECK(around >= 3 && along >= 1, "tube needs 3 segments around and 1 along");
    mesh::Mesh m;
    const float circumference = 2.0f * kPi * radius;
    for (int j = 0; j <= along; ++j) {
        const float s = length * static_cast<float>(j) / static_cast<float>(along);
        mesh::Vec3 c, t;
        tubeFrame(length, s, c, t);
        // Frame across the tube: e1 = +y, e2 = t x e1 (the bend stays in the xz plane).
        const mesh::Vec3 e1{0.0f, 1.0f, 0.0f};
        const mesh::Vec3 e2{t[1] * e1[2] - t[2] * e1[1], t[2] * e1[0] - t[0] * e1[2], t[0] * e1[1] - t[1] * e1[0]};
        for (int i = 0; i <= around; ++i) {
            const float u = static_cast<float>(i) / static_cast<float>(around), a = 2.0f * kPi * u;
            const mesh::Vec3 radial{std::cos(a) * e1[0] + std::sin(a) * e2[0],
                                    std::cos(a) * e1[1] + std::sin(a) * e2[1],
                                    std::cos(a) * e1[2] + std::sin(a) * e2[2]};
            m.positions.push_back({c[0] + radius * radial[0], c[1] + radius * radial[1], c[2] + radius * radial[2]});
            m.normals.push_back({-radial[0], -radial[1], -radial[2]});  // into the lumen
            m.uvs.push_back({u, s / circumference});
            // dP/du = d(radial)/da; dP/dv = t. With N = -radial: cross(N, T) = -t x ... -> w fixes B = +t.
            const mesh::Vec3 T{-std::sin(a) * e1[0] + std::cos(a) * e2[0], -std::sin(a) * e1[1] + std::cos(a) * e2[1],
                               -std::sin(a) * e1[2] + std::cos(a) * e2[2]};
            const mesh::Vec3 N{-radial[0], -radial[1], -radial[2]};
            const mesh::Vec3 NxT{N[1] * T[2] - N[2] * T[1], N[2] * T[0] - N[0] * T[2], N[0] * T[1] - N[1] * T[0]};
            const float w = (NxT[0] * t[0] + NxT[1] * t[1] + NxT[2] * t[2]) >= 0 ? 1.0f : -1.0f;
            m.tangents.push_back({T[0], T[1], T[2], w});
        }
    }
    // Wind counter-clockwise seen from inside (the normals' side).
    for (int j = 0; j < along; ++j)
        for (int i = 0; i < around; ++i) {
            const auto a = static_cast<std::uint32_t>(j * (around + 1) + i), b = a + 1,
                       c = a + static_cast<std::uint32_t>(around + 1), d = c + 1;
            m.indices.insert(m.indices.end(), {a, d, b, a, c, d});
        }
    return m;
}

std::vector<mesh::Vec3> tubeCenterline(float length, int samples) {
    std::vector<mesh::Vec3> pts;
    for (int i = 0; i < samples; ++i) {
        mesh::Vec3 c, t;
        tubeFrame(length, length * static_cast<float>(i) / static_cast<float>(std::max(samples - 1, 1)), c, t);
        pts.push_back(c);
    }
    return pts;
}

image::Image8 tissueTexture(int size, std::uint64_t seed) {
    MUCOSA_CHECK(size >= 8, "texture size must be at least 8");
    const std::size_t n = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    std::vector<float> mottle(n), vessels(n);
    noise::FractalParams m;
    m.frequency = 6;
    m.octaves = 5;
    m.seed = seed;
    m.tileable = true;
    m.z = 0.37;
    noise::fillFractal(m, std::span<float>(mottle), size, size);
    noise::FractalParams v = m;
    v.frequency = 3;
    v.octaves = 4;
    v.gain = 0.45;
    v.z = 0.71;
    noise::fillFractal(v, std::span<float>(vessels), size, size);
    image::Image8 img(size, size, 3);
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * size + x;
            const float shade = 0.92f + 0.16f * mottle[i];
            // Vessels: thin ridges where the noise crosses zero.
            const float ridge = std::max(0.0f, 1.0f - std::abs(vessels[i]) * 9.0f);
            const float vessel = ridge * ridge;
            const float r = shade * (1.0f - 0.12f * vessel), g = shade * (1.0f - 0.45f * vessel),
                        b = shade * (1.0f - 0.40f * vessel);
            img.at(x, y, 0) = static_cast<std::uint8_t>(std::lround(std::clamp(r, 0.0f, 1.0f) * 255.0f));
            img.at(x, y, 1) = static_cast<std::uint8_t>(std::lround(std::clamp(g, 0.0f, 1.0f) * 255.0f));
            img.at(x, y, 2) = static_cast<std::uint8_t>(std::lround(std::clamp(b, 0.0f, 1.0f) * 255.0f));
        }
    return img;
}

}  // namespace mucosa::render
