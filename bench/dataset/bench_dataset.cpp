// Dataset throughput: frames per second of `mucosa render
// --outputs` with every ground-truth output against the colour frame alone,
// at 640x480 and 1350x1080 (C3VD's size), on the default scene (the
// phantom, 141 k triangles), and where the time goes: the GL frame (draw and
// readback), PNG encoding, the ground truth (z-buffer, field of view, branch
// labels, flow) and writing its files (EXR and 16-bit PNG encoding).
// Then the same frames through a fisheye: the GL frame and the ground truth
// against the pinhole's.
// Everything runs one stage after another on this thread, so each stage is
// timed alone (the CLI overlaps the writing with the next frame: bench/README).
//
// Usage: bench_dataset [frames=20]
#include <sys/resource.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>

#include <mucosa/core/file.hpp>
#include <mucosa/dataset/ground_truth.hpp>
#include <mucosa/dataset/lens.hpp>
#include <mucosa/dataset/raycast.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/render/offscreen.hpp>
#include <mucosa/scene/scene.hpp>

using namespace mucosa;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

constexpr std::array<const char*, 7> kTruthOutputs = {"depth", "normals", "mask", "uv", "face", "flow", "branch"};

double since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

struct Times {
    double gl = 0, png = 0, truth = 0, write = 0;
    double total() const { return gl + png + truth + write; }
};

}  // namespace

int main(int argc, char** argv) {
    const int frames = argc > 1 ? std::atoi(argv[1]) : 20;
    if (frames < 2) {
        std::fprintf(stderr, "usage: bench_dataset [frames >= 2]\n");
        return 2;
    }
    const fs::path dir = fs::temp_directory_path() / ("mucosa_bench_dataset_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    for (const auto& [w, h] : {std::pair{640, 480}, std::pair{1350, 1080}}) {
        scene::Scene scene = scene::defaultScene();
        scene.width = w;
        scene.height = h;
        const scene::SceneAssets assets = scene::loadAssets(scene);
        const std::vector<camera::Pose> poses = scene::cameraPoses(scene, assets, frames);
        render::OffscreenSession session(scene, assets, w, h);
        const frames::Intrinsics K = dataset::intrinsicsOf(scene.lens, w, h);
        const auto t0 = Clock::now();
        const std::vector<std::int32_t> vertexBranch = dataset::vertexBranches(assets.mesh, assets.centerlineTree);
        const double branchSetup = since(t0);
        Times rgbOnly, full;
        std::array<double, kTruthOutputs.size()> perOutput{};
        double raster = 0;
        for (const bool withTruth : {false, true}) {
            Times& t = withTruth ? full : rgbOnly;
            std::optional<dataset::GroundTruth> previous;
            for (int i = 0; i < frames; ++i) {
                const fs::path name = dir / render::frameName("f.png", i);
                shading::FrameSetup f =
                    scene::frameSetup(scene, poses[static_cast<std::size_t>(i)], scene.width, scene.height);
                f.frameIndex = i;
                auto s = Clock::now();
                const image::Image8 img = session.renderFrame(f);
                t.gl += since(s);
                s = Clock::now();
                writeFileAtomic(name, image::encodePng(img));
                t.png += since(s);
                if (!withTruth) continue;
                s = Clock::now();
                const frames::Mat4 c2w = dataset::cameraToWorldOf(poses[static_cast<std::size_t>(i)]);
                dataset::GroundTruth g = dataset::groundTruth(assets.mesh, K, c2w, scene.lens.nearMm);
                raster += since(s);
                g.inView = dataset::fieldOfView(f);
                dataset::labelBranches(g, assets.mesh, vertexBranch);
                dataset::flowToPrevious(g, K, c2w, i > 0 ? &*previous : nullptr,
                                        dataset::cameraToWorldOf(poses[static_cast<std::size_t>(i > 0 ? i - 1 : 0)]),
                                        scene.lens.nearMm);
                t.truth += since(s);
                // Each output's files on their own, to see where the time goes.
                for (std::size_t k = 0; k < kTruthOutputs.size(); ++k) {
                    s = Clock::now();
                    dataset::writeGroundTruth(g, name, dataset::parseOutputs(kTruthOutputs[k], "", ""));
                    const double dt = since(s);
                    t.write += dt;
                    perOutput[k] += dt;
                }
                previous = std::move(g);
            }
        }
        const double n = frames;
        std::printf("%dx%d, %d frames, %s\n", w, h, frames, session.glRendererName().c_str());
        std::printf("  rgb only:     %.3f s/frame (%.1f frames/s): GL %.3f, PNG %.3f\n", rgbOnly.total() / n,
                    n / rgbOnly.total(), rgbOnly.gl / n, rgbOnly.png / n);
        std::printf(
            "  all outputs:  %.3f s/frame (%.1f frames/s): GL %.3f, PNG %.3f, ground truth %.3f (z-buffer %.3f), "
            "writing it %.3f\n",
            full.total() / n, n / full.total(), full.gl / n, full.png / n, full.truth / n, raster / n, full.write / n);
        std::printf("  writing, per output:");
        for (std::size_t k = 0; k < kTruthOutputs.size(); ++k)
            std::printf(" %s %.3f", kTruthOutputs[k], perOutput[k] / n);
        std::printf("\n  ratio all / rgb: %.2f (target <= 1.5); branch labels' setup once: %.2f s\n",
                    full.total() / rgbOnly.total(), branchSetup);
        std::fflush(stdout);

        // Through a fisheye (equidistant, 160 degrees across the diagonal):
        // the cube map's faces and the remap against the pinhole's frame, and
        // the ground truth by ray casting (the tree built once) against the
        // pinhole's z-buffer.
        const dataset::Lens lens = dataset::equidistantFisheye(w, h, 160.0);
        auto s = Clock::now();
        const dataset::RayCaster caster(assets.mesh);
        const double tree = since(s);
        session.renderer().setLensRays(dataset::rayImage(lens));
        const int faceSize = session.renderer().cubeFaceSize();
        double fisheyeGl = 0, fisheyeTruth = 0;
        for (int i = 0; i < frames; ++i) {
            shading::FrameSetup f =
                scene::frameSetup(scene, poses[static_cast<std::size_t>(i)], scene.width, scene.height);
            f.frameIndex = i;
            s = Clock::now();
            const image::Image8 img = session.renderFrame(f);
            fisheyeGl += since(s);
            s = Clock::now();
            const dataset::GroundTruth g = dataset::groundTruth(
                caster, lens, dataset::cameraToWorldOf(poses[static_cast<std::size_t>(i)]), scene.lens.nearMm);
            fisheyeTruth += since(s);
        }
        session.renderer().setLensRays({});
        std::printf(
            "  fisheye 160 deg (%d-px cube faces): GL %.3f s/frame (%.2f x the pinhole's %.3f); ground truth "
            "by ray casting %.3f s/frame (%.2f x the pinhole's z-buffer %.3f; tree once %.2f s)\n",
            faceSize, fisheyeGl / n, fisheyeGl / rgbOnly.gl, rgbOnly.gl / n, fisheyeTruth / n, fisheyeTruth / raster,
            raster / n, tree);
        std::fflush(stdout);
    }
    fs::remove_all(dir);
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    std::printf("peak memory %.0f MB\n", static_cast<double>(ru.ru_maxrss) / 1024.0);
}
