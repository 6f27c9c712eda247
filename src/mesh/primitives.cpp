#include <mucosa/mesh/primitives.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

#include <mucosa/core/error.hpp>

namespace mucosa::mesh {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;

void gridIndices(Mesh& m, int cols, int rows) {
    // (cols + 1) x (rows + 1) vertices, counter-clockwise seen from the normal side.
    for (int j = 0; j < rows; ++j)
        for (int i = 0; i < cols; ++i) {
            const auto a = static_cast<std::uint32_t>(j * (cols + 1) + i), b = a + 1,
                       c = a + static_cast<std::uint32_t>(cols + 1), d = c + 1;
            m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
        }
}

// Tube centerline: straight for the first third, then an arc bending towards +x.
void tubeFrame(float length, float s, Vec3& c, Vec3& t) {
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

Mesh makeQuad(float size, int n, bool mirrorU) {
    MUCOSA_CHECK(n >= 1, "quad needs at least one cell");
    Mesh m;
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

Mesh makeSphere(float radius, int slices, int stacks) {
    MUCOSA_CHECK(slices >= 3 && stacks >= 2, "sphere needs 3 slices and 2 stacks");
    Mesh m;
    for (int j = 0; j <= stacks; ++j) {
        const float v = static_cast<float>(j) / static_cast<float>(stacks), theta = kPi * (v - 0.5f);  // latitude
        for (int i = 0; i <= slices; ++i) {
            const float u = static_cast<float>(i) / static_cast<float>(slices), phi = 2.0f * kPi * u;
            const Vec3 n{std::cos(theta) * std::cos(phi), std::cos(theta) * std::sin(phi), std::sin(theta)};
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

Mesh makeTube(float radius, float length, int around, int along) {
    MUCOSA_CHECK(around >= 3 && along >= 1, "tube needs 3 segments around and 1 along");
    Mesh m;
    const float circumference = 2.0f * kPi * radius;
    for (int j = 0; j <= along; ++j) {
        const float s = length * static_cast<float>(j) / static_cast<float>(along);
        Vec3 c, t;
        tubeFrame(length, s, c, t);
        // Frame across the tube: e1 = +y, e2 = t x e1 (the bend stays in the xz plane).
        const Vec3 e1{0.0f, 1.0f, 0.0f};
        const Vec3 e2{t[1] * e1[2] - t[2] * e1[1], t[2] * e1[0] - t[0] * e1[2], t[0] * e1[1] - t[1] * e1[0]};
        for (int i = 0; i <= around; ++i) {
            const float u = static_cast<float>(i) / static_cast<float>(around), a = 2.0f * kPi * u;
            const Vec3 radial{std::cos(a) * e1[0] + std::sin(a) * e2[0], std::cos(a) * e1[1] + std::sin(a) * e2[1],
                              std::cos(a) * e1[2] + std::sin(a) * e2[2]};
            m.positions.push_back({c[0] + radius * radial[0], c[1] + radius * radial[1], c[2] + radius * radial[2]});
            m.normals.push_back({-radial[0], -radial[1], -radial[2]});  // into the lumen
            m.uvs.push_back({u, s / circumference});
            // dP/du = d(radial)/da; dP/dv = t. With N = -radial: cross(N, T) = -t x ... -> w fixes B = +t.
            const Vec3 T{-std::sin(a) * e1[0] + std::cos(a) * e2[0], -std::sin(a) * e1[1] + std::cos(a) * e2[1],
                         -std::sin(a) * e1[2] + std::cos(a) * e2[2]};
            const Vec3 N{-radial[0], -radial[1], -radial[2]};
            const Vec3 NxT{N[1] * T[2] - N[2] * T[1], N[2] * T[0] - N[0] * T[2], N[0] * T[1] - N[1] * T[0]};
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

std::vector<Vec3> tubeCenterline(float length, int samples) {
    std::vector<Vec3> pts;
    for (int i = 0; i < samples; ++i) {
        Vec3 c, t;
        tubeFrame(length, length * static_cast<float>(i) / static_cast<float>(std::max(samples - 1, 1)), c, t);
        pts.push_back(c);
    }
    return pts;
}

}  // namespace mucosa::mesh
