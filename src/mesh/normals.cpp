#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mucosa/core/memory.hpp>
#include <mucosa/core/parallel.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/repair.hpp>

#include "adjacency.hpp"
#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;

void recomputeNormals(Mesh& mesh, int threads) {
    validateIndices(mesh);
    const std::size_t n = mesh.vertexCount();
    requireMemory(saturatingMul(n, sizeof(Vec3) + 4) + saturatingMul(mesh.indices.size(), 4), "normals");
    const VertexCorners vc = vertexCorners(mesh);
    mesh.normals.assign(n, Vec3{0, 0, 1});
    const auto* P = mesh.positions.data();
    const auto* idx = mesh.indices.data();
    tbb::task_arena arena(resolveThreads(threads));
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t v = r.begin(); v != r.end(); ++v) {
                // Angle-weighted pseudo-normal (Thürmer & Wüthrich 1998):
                // N = normalize(sum_t alpha_t n_t), n_t the unit face normal.
                Vec3d sum{0, 0, 0};
                for (std::uint32_t k = vc.offsets[v]; k < vc.offsets[v + 1]; ++k) {
                    const std::uint32_t c = vc.corners[k], t = c - c % 3, j = c % 3;
                    const Vec3d p0 = toD(P[idx[t + j]]), p1 = toD(P[idx[t + (j + 1) % 3]]),
                                p2 = toD(P[idx[t + (j + 2) % 3]]);
                    const Vec3d nt = normalizeOr(cross(p1 - p0, p2 - p0), Vec3d{0, 0, 0});
                    const double alpha = cornerAngle(p0, p1, p2);
                    if (std::isfinite(alpha)) sum += nt * alpha;
                }
                mesh.normals[v] = toF(normalizeOr(sum, Vec3d{0, 0, 1}));
            }
        });
    });
}

}  // namespace mucosa::mesh
