// Outputs of `mucosa fit`: brdf.json, the atlas, coverage, and a report with
// the fitted curves plotted over the binned data.
#include <mucosa/fit/fit.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/version.hpp>
#include <mucosa/image/png.hpp>

namespace mucosa::fit {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A small line plot: curve y = f(x) on [x0, x1] plus data points.
template <class F>
std::string svgPlot(const std::string& title, const std::string& xlabel, const std::string& ylabel, double x0,
                    double x1, F f, const std::vector<std::array<double, 3>>& points) {
    const int W = 420, H = 300, L = 55, R = 15, T = 30, B = 45;
    double y0 = 1e300, y1 = -1e300;
    for (int i = 0; i <= 100; ++i) {
        const double y = f(x0 + (x1 - x0) * i / 100.0);
        y0 = std::min(y0, y);
        y1 = std::max(y1, y);
    }
    for (const auto& p : points) {
        y0 = std::min(y0, p[1]);
        y1 = std::max(y1, p[1]);
    }
    y0 = std::min(y0, 0.0);
    y1 = y1 + 0.1 * (y1 - y0 + 1e-9);
    auto X = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
    auto Y = [&](double y) { return H - B - (y - y0) / (y1 - y0) * (H - T - B); };
    std::string s = fmt::format(
        R"(<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" font-family="sans-serif" font-size="12">)"
        "\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
        W, H);
    s += fmt::format(R"(<text x="{}" y="18" text-anchor="middle" font-size="14">{}</text>)"
                     "\n",
                     W / 2, title);
    s += fmt::format(
        R"(<line x1="{0}" y1="{1}" x2="{2}" y2="{1}" stroke="black"/><line x1="{0}" y1="{3}" x2="{0}" y2="{1}" stroke="black"/>)"
        "\n",
        L, H - B, W - R, T);
    for (int i = 0; i <= 4; ++i) {
        const double xv = x0 + (x1 - x0) * i / 4, yv = y0 + (y1 - y0) * i / 4;
        s += fmt::format(R"(<text x="{:.1f}" y="{}" text-anchor="middle">{:.2f}</text>)"
                         R"(<text x="{}" y="{:.1f}" text-anchor="end">{:.2f}</text>)"
                         "\n",
                         X(xv), H - B + 16, xv, L - 6, Y(yv) + 4, yv);
    }
    s += fmt::format(R"(<text x="{}" y="{}" text-anchor="middle">{}</text>)"
                     R"(<text x="14" y="{}" text-anchor="middle" transform="rotate(-90 14 {}) ">{}</text>)"
                     "\n",
                     (L + W - R) / 2, H - 8, xlabel, (T + H - B) / 2, (T + H - B) / 2, ylabel);
    for (const auto& p : points)
        s += fmt::format(R"(<circle cx="{:.1f}" cy="{:.1f}" r="3" fill="#4a90d9"/>)"
                         "\n",
                         X(p[0]), Y(p[1]));
    std::string path;
    for (int i = 0; i <= 100; ++i) {
        const double x = x0 + (x1 - x0) * i / 100.0;
        path += fmt::format("{}{:.1f},{:.1f} ", i ? "L" : "M", X(x), Y(f(x)));
    }
    s += fmt::format(R"(<path d="{}" fill="none" stroke="#c0392b" stroke-width="2"/>)"
                     "\n</svg>\n",
                     path);
    return s;
}

}  // namespace

void writeFitOutputs(const FitResult& r, const fs::path& dir) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw IoError("output directory", dir.string(), ec.message());
    // Stage everything, then commit, so that a failure leaves no partial set.
    json brdf = shading::toJson(r.brdf);
    brdf["uv_min"] = r.uvMin;
    brdf["uv_max"] = r.uvMax;
    brdf["texture_size"] = r.texture.width();
    brdf["mucosa_version"] = std::string(version());

    image::Image16 tex(r.texture.width(), r.texture.height(), 3);
    for (std::size_t i = 0; i < tex.size(); ++i)
        tex.data()[i] = static_cast<std::uint16_t>(std::lround(std::clamp(r.texture.data()[i], 0.0f, 1.0f) * 65535.0f));
    std::vector<float> seen;
    for (std::size_t i = 0; i < r.coverage.size(); ++i)
        if (r.coverage.data()[i] > 0) seen.push_back(r.coverage.data()[i]);
    std::sort(seen.begin(), seen.end());
    const float ref = seen.empty() ? 1.0f : seen[seen.size() * 95 / 100];
    image::Image8 cov(r.coverage.width(), r.coverage.height(), 1);
    for (std::size_t i = 0; i < cov.size(); ++i) {
        const float w = r.coverage.data()[i];
        cov.data()[i] = w <= 0 ? 0 : static_cast<std::uint8_t>(64 + 191 * std::min(1.0f, w / ref));
    }

    const shading::BrdfParams& b = r.brdf;
    const std::string rhoSvg = svgPlot(
        "rho(gamma): view-angle shading", "gamma = cos(V, N)", "rho", 0.0, 1.0, [&](double g) { return b.rho(g); },
        r.rhoBins);
    const std::string deltaSvg = svgPlot(
        fmt::format("delta(r): distance shading, z in [{:.1f}, {:.1f}] mm", b.zmin, b.zmax),
        "r = (z - zmin) / (zmax - zmin)", "delta", 0.0, 1.0, [&](double x) { return b.delta(x); }, r.deltaBins);

    json rep{{"brdf", brdf},
             {"covered_fraction", r.coveredFraction},
             {"albedo_scale", r.albedoScale},
             {"solve",
              {{"samples", r.solveSamples},
               {"texels", r.solveTexels},
               {"iterations", r.solverIterations},
               {"seconds", r.solveSeconds}}},
             {"total_seconds", r.totalSeconds},
             {"atlas", {{"width", r.texture.width()}, {"height", r.texture.height()}, {"texel_mm", r.texelMm}}},
             {"falloff",
              {{"constrained", r.falloff.constrained},
               {"free_d", r.falloff.freeD},
               {"free_rise",
                {{"amount", r.falloff.rise.amount},
                 {"from_r", r.falloff.rise.from},
                 {"to_r", r.falloff.rise.to},
                 {"delta_from", r.falloff.rise.deltaFrom},
                 {"delta_to", r.falloff.rise.deltaTo},
                 {"sample_fraction", r.falloff.riseSampleFraction}}},
               {"free_cost", r.falloff.freeCost},
               {"constrained_cost", r.falloff.constrainedCost}}},
             {"warnings", r.warnings},
             {"frames", json::array()},
             {"holdout", json::array()}};
    for (std::size_t i = 0; i < r.perFrame.size(); ++i) {
        const auto& s = r.perFrame[i];
        rep["frames"].push_back({{"frame", i},
                                 {"pixels", s.pixels},
                                 {"hits", s.hits},
                                 {"back_facing", s.backFacing},
                                 {"saturated", s.saturated},
                                 {"outside_view", s.outsideView},
                                 {"grazing", s.grazing},
                                 {"samples", s.samples}});
    }
    std::string warningRows;
    for (const std::string& w : r.warnings) warningRows += fmt::format("<p><b>Warning:</b> {}</p>\n", w);
    if (r.albedoScale > 1)
        warningRows += fmt::format(
            "<p>The albedo came out brighter than 1 (the frames' exposure, with the vignetting divided out): the "
            "texture was divided by {:.3f} and rho multiplied by it, so rho(1) = {:.3f}.</p>\n",
            r.albedoScale, r.albedoScale);
    if (r.falloff.constrained)
        warningRows += fmt::format(
            "<p>&delta;(r) is constrained to be non-increasing and non-negative on [0, 1] (a lamp's fall-off); the "
            "free cubic was 1 + {:.4f} r + {:.4f} r&sup2; + {:.4f} r&sup3;.</p>\n",
            r.falloff.freeD[0], r.falloff.freeD[1], r.falloff.freeD[2]);
    std::string holdoutRows;
    for (const auto& h : r.holdout) {
        rep["holdout"].push_back({{"frame", h.frame},
                                  {"image", h.image},
                                  {"psnr_db", h.psnr},
                                  {"compared", h.compared},
                                  {"masked", h.masked}});
        holdoutRows += fmt::format("<tr><td>{}</td><td>{}</td><td>{:.2f}</td><td>{}</td><td>{}</td></tr>\n", h.frame,
                                   h.image, h.psnr, h.compared, h.masked);
    }
    const std::string html = fmt::format(
        R"(<!doctype html><html><head><meta charset="utf-8"><title>mucosa fit report</title>
<style>body{{font-family:sans-serif;margin:2em;max-width:60em}} td,th{{padding:2px 10px;text-align:right}}</style></head><body>
<h1>mucosa fit</h1>
<p>I = albedo &times; &rho;(&gamma;) &times; &delta;(r), &rho;(&gamma;) = c0 + c1 &gamma; + c2 &gamma;&sup2; + c3 &gamma;&sup3;, &delta;(r) = 1 + d1 r + d2 r&sup2; + d3 r&sup3;, r = (z &minus; zmin)/(zmax &minus; zmin).</p>
<table><tr><th>c0</th><th>c1</th><th>c2</th><th>c3</th><th>d1</th><th>d2</th><th>d3</th><th>zmin</th><th>zmax</th><th>samples</th><th>rms</th></tr>
<tr><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.2f}</td><td>{:.2f}</td><td>{}</td><td>{:.4f}</td></tr></table>
{}<p>Texture: {}&times;{} texels ({:.3f} mm each on the surface), {:.1f} % seen by a frame (the rest filled by push-pull inpainting). Solve: {} samples on {} texels, {} iterations, {:.2f} s; total {:.2f} s.</p>
{}
{}
<h2>Held-out frames</h2>
<p>PSNR of the re-rendered frame (texture &times; fitted shading) against the real one, over pixels that see the mesh, highlights and saturated pixels masked.</p>
<table><tr><th>frame</th><th>image</th><th>PSNR dB</th><th>pixels</th><th>masked</th></tr>
{}</table>
<p>Generated by Mucosa {}.</p></body></html>
)",
        b.c[0], b.c[1], b.c[2], b.c[3], b.d[0], b.d[1], b.d[2], b.zmin, b.zmax, b.samples, b.rms, warningRows,
        r.texture.width(), r.texture.height(), r.texelMm, 100.0 * r.coveredFraction, r.solveSamples, r.solveTexels,
        r.solverIterations, r.solveSeconds, r.totalSeconds, rhoSvg, deltaSvg,
        holdoutRows.empty() ? "<tr><td colspan=5>(none: use --holdout K)</td></tr>" : holdoutRows, version());

    AtomicFile fBrdf(dir / "brdf.json"), fTex(dir / "texture.png"), fCov(dir / "coverage.png"),
        fHtml(dir / "report.html"), fJson(dir / "report.json"), fRho(dir / "rho.svg"), fDelta(dir / "delta.svg");
    fBrdf.write(brdf.dump(2) + "\n");
    fTex.write(image::encodePng(tex));
    fCov.write(image::encodePng(cov));
    fHtml.write(html);
    fJson.write(rep.dump(2) + "\n");
    fRho.write(rhoSvg);
    fDelta.write(deltaSvg);
    for (AtomicFile* f : {&fBrdf, &fTex, &fCov, &fHtml, &fJson, &fRho, &fDelta}) f->commit();
}

}  // namespace mucosa::fit
