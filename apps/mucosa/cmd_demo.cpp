// mucosa demo: the main job on the built-in default, written to ./out/: the
// reflectance map, the paper's comparison, and the patient pipeline on a
// synthetic patient (out/patient/).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/fit/categories.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/reflectance/map.hpp>
#include <mucosa/register/patient.hpp>
#include <mucosa/register/register.hpp>
#include <mucosa/render/offscreen.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

namespace fs = std::filesystem;

std::string shownPath(const fs::path& p) {
    return fs::absolute(p).lexically_normal().string();
}

// Pose errors of a registration against the truth, frame by frame.
struct PoseScore {
    double medianMm = 0, p95Mm = 0, medianDeg = 0, p95Deg = 0;
    std::size_t converged = 0, frames = 0;
};
PoseScore scorePoses(const fs::path& registered, const fs::path& truth) {
    const frames::FrameSet r = frames::readFrames(registered), t = frames::readFrames(truth);
    std::vector<double> mm, deg;
    PoseScore s;
    for (std::size_t i = 0; i < std::min(r.frames.size(), t.frames.size()); ++i) {
        const registration::PoseError e = registration::poseError(r.frames[i].cameraToWorld, t.frames[i].cameraToWorld);
        mm.push_back(e.position);
        deg.push_back(e.degrees);
        s.converged += r.frames[i].flagged ? 0 : 1;
    }
    s.frames = mm.size();
    auto quantile = [](std::vector<double> v, double q) {
        std::sort(v.begin(), v.end());
        return v.empty() ? 0.0 : v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
    };
    s.medianMm = quantile(mm, 0.5), s.p95Mm = quantile(mm, 0.95);
    s.medianDeg = quantile(deg, 0.5), s.p95Deg = quantile(deg, 0.95);
    return s;
}

// PSNR (dB, sRGB-encoded 8-bit scale) of the fitted atlas against the truth's
// albedo over the texels the frames saw, after one gain (the video's
// exposure makes the albedo's scale unknowable).
struct TexturePsnr {
    double psnr = 0, gain = 1;
    std::size_t texels = 0;
};
TexturePsnr texturePsnr(const registration::SyntheticPatient& patient, const fs::path& fitDir) {
    const fit::FittedModel m = fit::readFitDirectory(fitDir);
    const image::PngImage coverage = image::readPng(fitDir / "coverage.png");
    const int w = m.texture.width(), h = m.texture.height();
    if (coverage.pixels.width() != w || coverage.pixels.height() != h)
        throw InputError("coverage", (fitDir / "coverage.png").string(), "does not match texture.png in size");
    std::vector<std::array<double, 3>> fitted, truth;
    double ft = 0, tt = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (coverage.pixels.at(x, y, 0) == 0) continue;
            const double u = m.uvMin[0] + (x + 0.5) / w * (m.uvMax[0] - m.uvMin[0]);
            const double v = m.uvMax[1] - (y + 0.5) / h * (m.uvMax[1] - m.uvMin[1]);  // first row = top
            const std::array<double, 3> a = registration::truthAlbedo(patient, u, v);
            std::array<double, 3> f{};
            for (int c = 0; c < 3; ++c) {
                f[static_cast<std::size_t>(c)] = m.texture.at(x, y, c);
                ft += f[static_cast<std::size_t>(c)] * a[static_cast<std::size_t>(c)];
                tt += f[static_cast<std::size_t>(c)] * f[static_cast<std::size_t>(c)];
            }
            fitted.push_back(f);
            truth.push_back(a);
        }
    TexturePsnr r;
    r.texels = fitted.size();
    if (r.texels == 0 || tt <= 0) return r;
    r.gain = ft / tt;
    auto encode = [](double linear) {  // sRGB (IEC 61966-2-1), as the texture is stored
        return 255.0 * (linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055);
    };
    double se = 0;
    for (std::size_t i = 0; i < fitted.size(); ++i)
        for (std::size_t c = 0; c < 3; ++c) {
            const double d = encode(std::clamp(r.gain * fitted[i][c], 0.0, 1.0)) - encode(truth[i][c]);
            se += d * d;
        }
    r.psnr = 10 * std::log10(255.0 * 255.0 / std::max(1e-12, se / (3.0 * static_cast<double>(fitted.size()))));
    return r;
}

// The patient pipeline a clinical user runs (README, "From a patient's video
// to poses"), on a synthetic patient whose truth it never reads.
void patientPipeline(const fs::path& dir, int frames, Global& g) {
    const fs::path input = dir / "input";
    info(g, fmt::format("patient: the phantom as the CT airway, {} frames of bronchoscopy at hidden poses", frames));
    registration::PatientOptions po;
    po.frames = frames;
    po.startMm = 85;  // the lower trachea: a short video still reaches the carina
    po.threads = g.threads;
    const registration::SyntheticPatient patient = registration::makeSyntheticPatient(po);
    registration::PatientWriteOptions wo;
    const bool tty = ::isatty(STDERR_FILENO) != 0;
    if (!g.quiet)
        wo.progress = [tty](int done, int total) {
            if (tty || done == total)
                std::fprintf(stderr, tty ? "\r[video] frame %d/%d\x1b[K" : "[video] %d frames\n", done, total);
            if (tty && done == total) std::fprintf(stderr, "\n");
        };
    registration::writeSyntheticPatient(patient, input, wo);
    const std::string mesh = (input / "airway.glb").string(), registered = (dir / "frames.json").string();
    // The steps, as a user types them.
    runCommand(g, {"register", "--mesh", mesh, "--video", (input / "video").string(), "--camera",
                   (input / "camera.json").string(), "--init", (input / "init.json").string(), "-o", registered,
                   "--report", (dir / "register_report").string(), "--restart"});
    runCommand(g, {"fit", "--mesh", mesh, "--frames", registered, "-o", (dir / "fit").string(), "--texture-size", "512",
                   "--holdout", "2"});
    runCommand(g, {"categories", "--mesh", mesh, "--fit", (dir / "fit").string(), "--frames", registered, "-o",
                   (dir / "stimuli").string()});
    runCommand(g, {"study", "plan", "--manifest", (dir / "stimuli" / "images.json").string(), "-o",
                   (dir / "study.json").string()});
    // Scored against the truth the pipeline never saw.
    const PoseScore ps = scorePoses(registered, input / "truth" / "frames.json");
    const TexturePsnr tp = texturePsnr(patient, dir / "fit");
    info(g, fmt::format("patient: {} of {} frames converged; pose error median {:.2f} mm / {:.2f} deg, p95 {:.2f} mm / "
                        "{:.2f} deg",
                        ps.converged, ps.frames, ps.medianMm, ps.medianDeg, ps.p95Mm, ps.p95Deg));
    info(g, fmt::format("patient: recovered texture PSNR {:.1f} dB against the truth over {} seen "
                        "(after one gain, {:.2f})",
                        tp.psnr, count(tp.texels, "texel"), tp.gain));
    info(g, fmt::format("  registration report: {}", shownPath(dir / "register_report" / "index.html")));
    info(g, fmt::format("  fit report:          {}", shownPath(dir / "fit" / "report.html")));
    info(g, fmt::format("  study stimuli:       {}", shownPath(dir / "stimuli")));
    info(g, fmt::format("  study plan:          {}", shownPath(dir / "study.json")));
}

void addDemoCommand(CLI::App& app, Global& g) {
    auto outDir = std::make_shared<std::string>("out");
    auto patientFrames = std::make_shared<int>(40);
    CLI::App* c =
        app.add_subcommand("demo", "Run the whole pipeline on the built-in default and write results to ./out/");
    c->add_option("-o,--output-dir", *outDir, "Output folder, created if its parent exists [out]");
    c->add_option("--patient-frames", *patientFrames,
                  "Frames of the synthetic patient's video (register -> fit -> categories -> study plan into "
                  "<output>/patient/; 0 = skip) [40]")
        ->check(wholeNumber(0, 100000));
    c->callback([outDir, patientFrames, &g] {
        const fs::path dir = *outDir;
        // As every other command's output: the folder is created, its parents must exist.
        requireOutputDir(dir);
        std::error_code ec;
        fs::create_directory(dir, ec);
        if (ec) throw IoError("output folder", dir.string(), ec.message());
        const reflectance::Preset& preset = reflectance::findPreset("bronchial");
        reflectance::MapOutputs out;
        out.map = dir / "reflectance_map.png";
        out.height = dir / "height.png";
        const reflectance::MapReport r = reflectance::generateMap(preset.params, out, g.threads);
        for (const std::string& w : r.warnings) warn(w);
        info(g, fmt::format("demo: '{}' preset, {}x{} texels", preset.name, preset.params.size, preset.params.size));
        info(g, fmt::format("  reflectance map: {}", fs::absolute(out.map).lexically_normal().string()));
        info(g, fmt::format("  height map:      {}", fs::absolute(*out.height).lexically_normal().string()));
        info(g, fmt::format("  parameters:      {}", fs::absolute(r.sidecar).lexically_normal().string()));
        render::writeDefaultCompareSheet(dir / "compare.png", g.threads);  // the paper's Fig. 2 and 3
        info(g, fmt::format("  comparison:      {}", fs::absolute(dir / "compare.png").lexically_normal().string()));
        if (*patientFrames > 0) {
            fs::create_directory(dir / "patient", ec);
            if (ec) throw IoError("output folder", (dir / "patient").string(), ec.message());
            patientPipeline(dir / "patient", *patientFrames, g);
        }
    });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(100, addDemoCommand);

}  // namespace mucosa::cli
