#include <algorithm>
#include <cmath>
#include <vector>

#include <mucosa/core/error.hpp>
#include <mucosa/mesh/analysis.hpp>
#include <mucosa/mesh/io.hpp>

#include "vecmath.hpp"

namespace mucosa::mesh {

using namespace detail;

namespace {
double percentile(std::vector<double>& v, double q) {
    if (v.empty()) return 0;
    const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}
}  // namespace

UvStretch measureUvStretch(const Mesh& mesh) {
    if (!mesh.hasUvs()) throw InputError("uv stretch", "", "the mesh has no texture coordinates");
    validateIndices(mesh);
    const std::size_t m = mesh.triangleCount();
    std::vector<double> area3(m), areaUv(m), aniso;
    aniso.reserve(m);
    double total3 = 0, totalUv = 0;
    std::size_t positive = 0, negative = 0;
    for (std::size_t t = 0; t < m; ++t) {
        const std::uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
        const Vec3d p0 = toD(mesh.positions[a]), Q1 = toD(mesh.positions[b]) - p0, Q2 = toD(mesh.positions[c]) - p0;
        const double s1 = double(mesh.uvs[b][0]) - mesh.uvs[a][0], t1 = double(mesh.uvs[b][1]) - mesh.uvs[a][1];
        const double s2 = double(mesh.uvs[c][0]) - mesh.uvs[a][0], t2 = double(mesh.uvs[c][1]) - mesh.uvs[a][1];
        const double det = s1 * t2 - s2 * t1;
        area3[t] = 0.5 * length(cross(Q1, Q2));
        areaUv[t] = 0.5 * std::abs(det);
        total3 += area3[t];
        totalUv += areaUv[t];
        if (det > 0) ++positive;
        if (det < 0) ++negative;
        // Jacobian of surface -> uv in an orthonormal frame of the triangle:
        // J maps (x, y) in-plane to (u, v); its singular values are sigma1 >= sigma2.
        const double l1 = length(Q1);
        if (!(area3[t] > 0) || !(l1 > 0)) continue;
        const Vec3d e1 = Q1 * (1.0 / l1);
        const Vec3d e2 = normalizeOr(Q2 - e1 * dot(Q2, e1), Vec3d{0, 0, 0});
        const double x1 = l1, x2 = dot(Q2, e1), y2 = dot(Q2, e2);  // Q1 = (x1, 0), Q2 = (x2, y2)
        if (!(std::abs(y2) > 0)) continue;
        // [s1 s2; t1 t2] = J [x1 x2; 0 y2]  =>  J = [s1 s2; t1 t2] [x1 x2; 0 y2]^-1
        const double a11 = s1 / x1, a21 = t1 / x1;
        const double a12 = (s2 - a11 * x2) / y2, a22 = (t2 - a21 * x2) / y2;
        const double E = a11 * a11 + a21 * a21, G = a12 * a12 + a22 * a22, F = a11 * a12 + a21 * a22;
        const double root = std::sqrt(std::max(0.0, (E - G) * (E - G) + 4 * F * F));
        const double sigma1 = std::sqrt(std::max(0.0, 0.5 * (E + G + root)));
        const double sigma2 = std::sqrt(std::max(0.0, 0.5 * (E + G - root)));
        if (sigma2 > 0) aniso.push_back(sigma1 / sigma2);
    }
    UvStretch s;
    s.uvPerSurfaceArea = total3 > 0 ? totalUv / total3 : 0;
    std::vector<double> ratio;
    ratio.reserve(m);
    const double meanUv = m ? totalUv / static_cast<double>(m) : 0;
    for (std::size_t t = 0; t < m; ++t) {
        if (areaUv[t] < 1e-12 * meanUv) ++s.zeroUvAreaTriangles;
        if (area3[t] > 0 && s.uvPerSurfaceArea > 0) ratio.push_back(areaUv[t] / area3[t] / s.uvPerSurfaceArea);
    }
    s.areaP05 = percentile(ratio, 0.05);
    s.areaP50 = percentile(ratio, 0.50);
    s.areaP95 = percentile(ratio, 0.95);
    s.anisotropyP50 = percentile(aniso, 0.50);
    s.anisotropyP95 = percentile(aniso, 0.95);
    s.flippedTriangles = std::min(positive, negative);
    return s;
}

}  // namespace mucosa::mesh
