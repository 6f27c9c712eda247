// mucosa fit: patient-specific texture and BRDF from registered frames.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/fit/fit.hpp>
#include <mucosa/mesh/io.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

struct FitArgs {
    std::string mesh, frames, out;
    fit::FitOptions o;
    bool noRobust = false;
};

void addFitCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<FitArgs>();
    CLI::App* c =
        app.add_subcommand("fit", "Fit the paper's BRDF (rho, delta) and a texture atlas to registered frames");
    c->footer("Example: mucosa fit --mesh airway_uv.glb --frames frames.json -o fit/ --texture-size 1024 --holdout 2");
    c->add_option("--mesh", a->mesh, "Mesh with texture coordinates (any format `mucosa mesh` reads)")->required();
    c->add_option("--frames", a->frames, "Frames file (JSON: images, intrinsics, camera_to_world)")->required();
    c->add_option("-o,--output", a->out, "Output directory")->required();
    c->add_option("--texture-size", a->o.textureSize, "Texels per side of the albedo atlas [1024]");
    c->add_option("--holdout", a->o.holdout, "Frames held out and re-rendered for validation (PSNR) [0]");
    c->add_flag("--no-robust", a->noRobust, "Plain least squares instead of the Cauchy loss (for comparison)");
    c->add_option("--loss-scale", a->o.cauchyScale, "Residual scale of the Cauchy loss, linear intensity [0.02]");
    c->callback([a, &g] {
        a->o.threads = g.threads;
        a->o.robust = !a->noRobust;
        requireOutputDir(a->out);  // before the work, not after it
        const bool tty = ::isatty(STDERR_FILENO) != 0;
        const auto start = std::chrono::steady_clock::now();
        // One fraction for the whole command, never going back: reading the
        // inputs, the fit (its own 0..1 mapped into kFitFrom..kFitTo), writing.
        constexpr double kFitFrom = 0.02, kFitTo = 0.92, kWriting = 0.95;
        auto shown = std::make_shared<double>(0.0);
        auto report = [&g, tty, start, shown](const std::string& stage, double fraction) {
            if (g.quiet) return;
            *shown = std::max(*shown, fraction);
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            std::fprintf(stderr, tty ? "\r[fit %3.0f%%] %-48s %6.1f s\x1b[K" : "[fit %3.0f%%] %s (%.1f s)\n",
                         100.0 * *shown, stage.c_str(), s);
            if (tty && *shown >= 1.0) std::fprintf(stderr, "\n");
            std::fflush(stderr);
        };
        a->o.progress = [report](const std::string& stage, double fraction) {
            report(stage, kFitFrom + (kFitTo - kFitFrom) * std::clamp(fraction, 0.0, 1.0));
        };
        report("reading " + a->frames + " and " + a->mesh, 0.0);
        frames::FrameSet frames = frames::readFrames(a->frames);
        // Frames `mucosa register` could not register carry a wrong pose.
        const auto flagged = std::erase_if(frames.frames, [](const frames::Frame& f) { return f.flagged; });
        if (flagged > 0)
            warn(fmt::format("skipping {} of {} that mucosa register flagged as not converged", count(flagged, "frame"),
                             a->frames));
        if (frames.frames.empty())
            throw InputError("frames", a->frames, "every frame is flagged as not converged by mucosa register");
        mesh::Mesh m = mesh::load(a->mesh);
        fit::FitResult r;
        try {
            r = fit::fitFrames(m, frames, a->o);
        } catch (const InputError& e) {
            // Errors about the mesh name the mesh file.
            if (e.subject() == "mesh" && e.file().empty()) throw InputError("mesh", a->mesh, e.reason());
            if (e.file().empty()) throw InputError(e.subject(), a->frames, e.reason());
            throw;
        }
        for (const std::string& w : r.warnings) warn(w);
        report("writing " + joinPath(a->out, "brdf.json") + ", texture.png, ...", kWriting);
        fit::writeFitOutputs(r, a->out);
        report("done", 1.0);
        const auto& b = r.brdf;
        info(g,
             fmt::format("rho(gamma) = {:.4f} + {:.4f} g + {:.4f} g^2 + {:.4f} g^3", b.c[0], b.c[1], b.c[2], b.c[3]));
        info(g, fmt::format("delta(r) = 1 + {:.4f} r + {:.4f} r^2 + {:.4f} r^3, z in [{:.2f}, {:.2f}] mm", b.d[0],
                            b.d[1], b.d[2], b.zmin, b.zmax));
        info(g, fmt::format("{} in the solve, rms {:.4f}; texture covers {:.1f} % of the atlas",
                            count(b.samples, "sample"), b.rms, 100.0 * r.coveredFraction));
        for (const auto& h : r.holdout)
            info(g, fmt::format("held-out frame {} ({}): PSNR {:.2f} dB over {} ({} masked)", h.frame, h.image, h.psnr,
                                count(h.compared, "pixel"), h.masked));
        info(g, "wrote " + joinPath(a->out, "{brdf.json, texture.png, coverage.png, report.html}"));
    });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(70, addFitCommand);

}  // namespace mucosa::cli
