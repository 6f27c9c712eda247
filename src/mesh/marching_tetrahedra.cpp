#include "marching_tetrahedra.hpp"

#include <algorithm>
#include <unordered_map>

#include "vecmath.hpp"

namespace mucosa::mesh::detail {

namespace {

// The six tetrahedra of the cube around the diagonal (0,0,0)-(1,1,1): for each
// permutation (a, b, c) of the axes, 0 -> e_a -> e_a + e_b -> 1.
constexpr int kAxisOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

struct Corner {
    int d[3];  // offset in the cube, 0/1 per axis
};

}  // namespace

Mesh marchingTetrahedra(const ScalarGrid& g) {
    Mesh m;
    if (g.nx < 2 || g.ny < 2 || g.nz < 2) return m;
    // Vertex per crossed edge; the edge is keyed by its lower sample and its
    // direction (a non-zero 0/1 vector: every edge of a Kuhn tetrahedron is monotone).
    std::unordered_map<std::uint64_t, std::uint32_t> edgeVertex;
    edgeVertex.reserve(1 << 16);
    auto sampleIndex = [&](std::size_t i, std::size_t j, std::size_t k) { return i + g.nx * (j + g.ny * k); };
    auto position = [&](std::size_t i, std::size_t j, std::size_t k) {
        return Vec3d{g.origin[0] + g.spacing * double(i), g.origin[1] + g.spacing * double(j),
                     g.origin[2] + g.spacing * double(k)};
    };

    for (std::size_t k = 0; k + 1 < g.nz; ++k)
        for (std::size_t j = 0; j + 1 < g.ny; ++j)
            for (std::size_t i = 0; i + 1 < g.nx; ++i) {
                float f[2][2][2];
                int inside = 0;
                for (int dz = 0; dz < 2; ++dz)
                    for (int dy = 0; dy < 2; ++dy)
                        for (int dx = 0; dx < 2; ++dx) {
                            f[dx][dy][dz] = g.at(i + dx, j + dy, k + dz);
                            inside += f[dx][dy][dz] < 0 ? 1 : 0;
                        }
                if (inside == 0 || inside == 8) continue;

                auto vertexOn = [&](const Corner& a, const Corner& b) -> std::uint32_t {
                    const Corner& lo = (a.d[0] <= b.d[0] && a.d[1] <= b.d[1] && a.d[2] <= b.d[2]) ? a : b;
                    const Corner& hi = &lo == &a ? b : a;
                    const std::size_t s = sampleIndex(i + lo.d[0], j + lo.d[1], k + lo.d[2]);
                    const int dir = (hi.d[0] - lo.d[0]) + 2 * (hi.d[1] - lo.d[1]) + 4 * (hi.d[2] - lo.d[2]) - 1;
                    const std::uint64_t key = std::uint64_t(s) * 7 + std::uint64_t(dir);
                    auto [it, inserted] = edgeVertex.try_emplace(key, static_cast<std::uint32_t>(m.positions.size()));
                    if (inserted) {
                        const float fa = f[lo.d[0]][lo.d[1]][lo.d[2]], fb = f[hi.d[0]][hi.d[1]][hi.d[2]];
                        // Linear interpolation, kept a hair away from the samples so
                        // no triangle collapses to zero area.
                        const double t = std::clamp(double(fa) / (double(fa) - double(fb)), 1e-3, 1.0 - 1e-3);
                        const Vec3d pa = position(i + lo.d[0], j + lo.d[1], k + lo.d[2]);
                        const Vec3d pb = position(i + hi.d[0], j + hi.d[1], k + hi.d[2]);
                        m.positions.push_back(toF(pa + (pb - pa) * t));
                    }
                    return it->second;
                };
                auto emit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c, const Corner& in,
                                const Corner& out) {
                    // Wind so the geometric normal faces the inside corner.
                    const Vec3d pa = toD(m.positions[a]), pb = toD(m.positions[b]), pc = toD(m.positions[c]);
                    const Vec3d n = cross(pb - pa, pc - pa);
                    const Vec3d toward{double(in.d[0] - out.d[0]), double(in.d[1] - out.d[1]),
                                       double(in.d[2] - out.d[2])};
                    if (dot(n, toward) < 0) std::swap(b, c);
                    m.indices.insert(m.indices.end(), {a, b, c});
                };

                for (const auto& order : kAxisOrders) {
                    Corner c[4] = {{{0, 0, 0}}, {{0, 0, 0}}, {{0, 0, 0}}, {{1, 1, 1}}};
                    c[1].d[order[0]] = 1;
                    c[2] = c[1];
                    c[2].d[order[1]] = 1;
                    Corner in[4], out[4];
                    int ni = 0, no = 0;
                    for (const Corner& q : c) {
                        if (f[q.d[0]][q.d[1]][q.d[2]] < 0)
                            in[ni++] = q;
                        else
                            out[no++] = q;
                    }
                    if (ni == 0 || no == 0) continue;
                    if (ni == 1) {
                        emit(vertexOn(in[0], out[0]), vertexOn(in[0], out[1]), vertexOn(in[0], out[2]), in[0], out[0]);
                    } else if (no == 1) {
                        emit(vertexOn(out[0], in[0]), vertexOn(out[0], in[1]), vertexOn(out[0], in[2]), in[0], out[0]);
                    } else {
                        // Two in, two out: the quad a0-b0, a0-b1, a1-b1, a1-b0.
                        const std::uint32_t q0 = vertexOn(in[0], out[0]), q1 = vertexOn(in[0], out[1]),
                                            q2 = vertexOn(in[1], out[1]), q3 = vertexOn(in[1], out[0]);
                        emit(q0, q1, q2, in[0], out[0]);
                        emit(q0, q2, q3, in[1], out[0]);
                    }
                }
            }
    return m;
}

}  // namespace mucosa::mesh::detail
