#pragma once
// Patient-specific shading (the paper's eq. 8-11, as reconstructed in
// DESIGN.md): with gamma = cos(V, N) and r = (z - zmin) / (zmax - zmin), z the
// distance from the surface point to the viewpoint,
//   rho(gamma) = c0 + c1 gamma + c2 gamma^2 + c3 gamma^3     (eq. 9)
//   delta(r)   = 1 + d1 r + d2 r^2 + d3 r^3                  (eq. 10)
//   I          = albedo(x) * rho(gamma) * delta(r)           (eq. 11)
// The scale is fixed by rho(1) = 1 and delta(0) = 1, so the albedo carries the
// absolute level; `mucosa fit` moves any level above 1 into rho (rho(1) > 1)
// so that its texture fits in [0, 1].
#include <array>
#include <filesystem>
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace mucosa::shading {

struct BrdfParams {
    std::array<double, 4> c{1.0, 0.0, 0.0, 0.0};
    std::array<double, 3> d{0.0, 0.0, 0.0};
    double zmin = 0.0, zmax = 1.0;  // mesh units (mm)
    std::size_t samples = 0;        // samples the fit used
    double rms = 0.0;               // RMS residual of inliers, linear intensity 0..1

    double rho(double gamma) const noexcept { return c[0] + gamma * (c[1] + gamma * (c[2] + gamma * c[3])); }
    double r(double z) const noexcept { return (z - zmin) / (zmax - zmin); }
    double delta(double rr) const noexcept { return 1.0 + rr * (d[0] + rr * (d[1] + rr * d[2])); }
    double shading(double gamma, double z) const noexcept { return rho(gamma) * delta(r(z)); }
};

// brdf.json: {"c": [c0..c3], "d": [d1..d3], "zmin", "zmax", "samples", "rms"}.
nlohmann::json toJson(const BrdfParams& p);
BrdfParams brdfFromJson(const nlohmann::json& j, const std::string& file);
BrdfParams readBrdf(const std::filesystem::path& path);

}  // namespace mucosa::shading
