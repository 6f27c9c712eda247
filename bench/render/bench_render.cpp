// bench_render [scene.json] [--frames N] [--sizes 640x480,1280x1024] [--modes noise,vertex-phong,...]
//              [--octaves 0,1,2,4,6,8]  (0: the map path, timed in the same rounds)
//              [--light-offset X,Y,Z]  (mm in the camera's frame; default: the scene's, the default
//                                       scene's is 0: the light at the eye, the renderer's headlight programs)
// A mode may carry "@bare": the mode without the endoscope's camera and the
// wet film (camera.* at identity, so no HDR target or post pass; no sheen,
// wrap or scattering): the frame as it was drawn before the camera existed, the peer of the
// default look's cost ("noise" vs "noise@bare").
// Frames per second of each shading mode, headless: every frame is drawn and
// finished with glFinish (no read-back), along the scene's camera path, after
// a warm-up. Shader compilation and texture upload happen before timing.
// Then the procedural mode's cost per octave: frame time at each octave count
// (first size), and the least-squares slope.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/render/offscreen.hpp>
#include <mucosa/scene/scene.hpp>

using namespace mucosa;

namespace {

constexpr int kRounds = 7;

std::vector<std::string> split(const std::string& s) {
    std::vector<std::string> out;
    std::size_t pos = 0;
    while (pos <= s.size()) {
        const auto c = s.find(',', pos);
        out.push_back(s.substr(pos, c == std::string::npos ? std::string::npos : c - pos));
        if (c == std::string::npos) break;
        pos = c + 1;
    }
    return out;
}

}  // namespace

// Median over rounds of a[r] / b[r].
double medianRatio(const std::vector<double>& a, const std::vector<double>& b) {
    std::vector<double> r;
    for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) r.push_back(a[i] / b[i]);
    if (r.empty()) return 0.0;
    std::sort(r.begin(), r.end());
    return r.size() % 2 ? r[r.size() / 2] : 0.5 * (r[r.size() / 2 - 1] + r[r.size() / 2]);
}

int main(int argc, char** argv) try {
    std::string sceneFile;
    int frames = 40;
    std::vector<std::string> sizes = {"640x480", "1280x1024"};
    std::vector<std::string> modes = {"noise", "noise@bare", "procedural", "vertex-phong", "multitexture", "diffuse"};
    std::vector<std::string> octaveCounts = {"0", "1", "2", "4", "6", "8"};  // 0: the map, for the ratios
    std::vector<std::string> lightOffset;                                    // empty: the scene's
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--frames" && i + 1 < argc)
            frames = std::atoi(argv[++i]);
        else if (a == "--sizes" && i + 1 < argc)
            sizes = split(argv[++i]);
        else if (a == "--modes" && i + 1 < argc)
            modes = split(argv[++i]);
        else if (a == "--octaves" && i + 1 < argc)
            octaveCounts = split(argv[++i]);
        else if (a == "--light-offset" && i + 1 < argc)
            lightOffset = split(argv[++i]);
        else if (a == "--help") {
            std::puts(
                "bench_render [scene.json] [--frames N] [--sizes WxH,...] [--modes m,...] [--octaves k,...] "
                "[--light-offset X,Y,Z]");
            return 0;
        } else
            sceneFile = a;
    }
    scene::Scene scene = sceneFile.empty() ? scene::defaultScene() : scene::loadScene(sceneFile);
    if (!lightOffset.empty()) {
        if (lightOffset.size() != 3) throw InputError("--light-offset", "", "needs X,Y,Z in mm");
        for (std::size_t k = 0; k < 3; ++k) scene.light.offset[k] = std::stof(lightOffset[k]);
    }
    const scene::SceneAssets assets = scene::loadAssets(scene);
    for (const auto& n : assets.notes) std::printf("%s\n", n.c_str());
    const std::vector<camera::Pose> poses = scene::cameraPoses(scene, assets, frames);
    std::map<std::string, std::map<std::string, double>> fps;
    std::map<int, double> octaveFps;  // procedural, first size
    // Frame times per round: ratios are taken round by round (both modes
    // measured seconds apart) and their median reported, which holds steady
    // on a shared machine whose speed drifts between rounds.
    std::map<std::string, std::map<std::string, std::vector<double>>> roundMs;
    std::map<int, std::vector<double>> octaveRoundMs;
    double firstPixels = 0;
    std::string rendererName;
    std::size_t drawnTriangles = 0;
    for (const std::string& size : sizes) {
        int w = 0, h = 0;
        if (std::sscanf(size.c_str(), "%dx%d", &w, &h) != 2) throw InputError("--sizes", "", size + " is not WxH");
        render::OffscreenSession session(scene, assets, w, h);
        rendererName = session.glRendererName();
        // Modes take turns, kRounds rounds, best round kept: a shared machine's
        // other load then hurts every mode alike.
        for (int round = 0; round < kRounds; ++round)
            for (const std::string& m : modes) {
                const bool bare = m.ends_with("@bare");
                const shading::Mode mode = shading::parseMode(bare ? m.substr(0, m.size() - 5) : m, "--modes");
                auto frame = [&](int i) {
                    shading::FrameSetup f =
                        scene::frameSetup(scene, poses[static_cast<std::size_t>(i) % poses.size()], w, h);
                    f.mode = mode;
                    f.frameIndex = i;
                    if (bare) {
                        using P = shading::Param;
                        shading::setCameraIdentity(f.params);
                        f.params.set(P::SheenStrength, 0.0f);
                        f.params.set(P::Wrap, 0.0f);
                        f.params.set(P::ScatterShare, 0.0f);
                    }
                    return f;
                };
                for (int i = 0; i < 2; ++i) session.draw(frame(i));
                session.finish();
                const auto t0 = std::chrono::steady_clock::now();
                std::size_t drawn = 0;
                for (int i = 0; i < frames; ++i) {
                    session.draw(frame(i));
                    session.finish();
                    drawn += session.renderer().lastDrawnTriangles();
                }
                const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                fps[size][m] = std::max(fps[size][m], frames / s);
                roundMs[size][m].push_back(1000.0 * s / frames);
                drawnTriangles = drawn / static_cast<std::size_t>(frames);
                std::fprintf(stderr, "round %d %s %s: %.1f fps\n", round + 1, size.c_str(), m.c_str(), frames / s);
            }
        // Cost per octave: the procedural mode with 1, 2, 4, ... octaves.
        if (&size == &sizes.front()) firstPixels = double(w) * h;
        if (&size == &sizes.front())
            for (int round = 0; round < kRounds; ++round)
                for (const std::string& k : octaveCounts) {
                    // 0: the map path (noise mode), in the same rounds as the octave counts.
                    const int octaves = std::atoi(k.c_str());
                    auto frame = [&](std::size_t i) {
                        shading::FrameSetup f = scene::frameSetup(scene, poses[i % poses.size()], w, h);
                        f.mode = octaves == 0 ? shading::Mode::Noise : shading::Mode::Procedural;
                        if (octaves > 0) f.procedural.noise.octaves = octaves;
                        return f;
                    };
                    session.draw(frame(0));
                    session.finish();
                    const auto t0 = std::chrono::steady_clock::now();
                    for (int i = 0; i < frames; ++i) session.draw(frame(static_cast<std::size_t>(i)));
                    session.finish();
                    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                    octaveFps[octaves] = std::max(octaveFps[octaves], frames / s);
                    octaveRoundMs[octaves].push_back(1000.0 * s / frames);
                    std::fprintf(stderr, "round %d %s procedural, %d octaves: %.1f fps\n", round + 1, size.c_str(),
                                 octaves, frames / s);
                }
    }
    std::printf("GL_RENDERER: %s\n", rendererName.c_str());
    std::printf(
        "mesh: %zu triangles (%zu drawn per frame on average after frustum culling), %d frames per "
        "measurement along the camera path, best of %d rounds\n",
        assets.mesh.triangleCount(), drawnTriangles, frames, kRounds);
    std::printf("light: tip light, offset (%g, %g, %g) mm%s\n\n", scene.light.offset[0], scene.light.offset[1],
                scene.light.offset[2],
                scene.light.offset == camera::Vec3{0, 0, 0} ? " (at the eye: headlight programs)" : "");
    std::printf("| mode |");
    for (const auto& s : sizes) std::printf(" %s fps |", s.c_str());
    std::printf("\n|---|");
    for (std::size_t i = 0; i < sizes.size(); ++i) std::printf("---|");
    std::printf("\n");
    for (const auto& m : modes) {
        std::printf("| %s |", m.c_str());
        for (const auto& s : sizes) std::printf(" %.1f |", fps[s][m]);
        std::printf("\n");
    }
    if (fps.begin()->second.count("noise") && fps.begin()->second.count("vertex-phong")) {
        std::printf("| frame-time ratio noise / vertex-phong (median of rounds) |");
        for (const auto& s : sizes)
            std::printf(" %.2f |", medianRatio(roundMs[s]["noise"], roundMs[s]["vertex-phong"]));
        std::printf("\n");
    }
    if (fps.begin()->second.count("noise") && fps.begin()->second.count("noise@bare")) {
        std::printf("| frame-time ratio noise (default look) / noise@bare (no camera, no film) (median of rounds) |");
        for (const auto& s : sizes) std::printf(" %.2f |", medianRatio(roundMs[s]["noise"], roundMs[s]["noise@bare"]));
        std::printf("\n");
    }
    if (fps.begin()->second.count("noise") && fps.begin()->second.count("procedural")) {
        std::printf("| frame-time ratio procedural (%d octaves) / noise (map) (median of rounds) |",
                    scene.mapParams.noise.octaves);
        for (const auto& s : sizes) std::printf(" %.2f |", medianRatio(roundMs[s]["procedural"], roundMs[s]["noise"]));
        std::printf("\n");
    }
    const double mapFps = octaveFps.count(0) ? octaveFps[0] : 0.0;
    octaveFps.erase(0);
    if (!octaveFps.empty()) {
        // Least-squares slope of frame time against the octave count.
        double sx = 0, sy = 0, sxx = 0, sxy = 0;
        for (const auto& [k, f] : octaveFps) {
            const double ms = 1000.0 / f;
            sx += k, sy += ms, sxx += double(k) * k, sxy += k * ms;
        }
        const double n = static_cast<double>(octaveFps.size());
        const double slope = (n * sxy - sx * sy) / std::max(n * sxx - sx * sx, 1e-12);
        std::printf("\nprocedural mode at %s, cost per octave (phantom, %s preset):\n\n| octaves |",
                    sizes.front().c_str(), scene.mapParams.preset.c_str());
        for (const auto& [k, f] : octaveFps) std::printf(" %d |", k);
        std::printf("\n|---|");
        for (std::size_t i = 0; i < octaveFps.size(); ++i) std::printf("---|");
        std::printf("\n| fps |");
        for (const auto& [k, f] : octaveFps) std::printf(" %.1f |", f);
        std::printf("\n| ms per frame |");
        for (const auto& [k, f] : octaveFps) std::printf(" %.2f |", 1000.0 / f);
        if (mapFps > 0) {
            std::printf("\n| frame time / map path's (%.2f ms; median of per-round ratios) |", 1000.0 / mapFps);
            for (const auto& [k, f] : octaveFps)
                std::printf(" %.2f |", medianRatio(octaveRoundMs[k], octaveRoundMs[0]));
        }
        std::printf("\n\nslope: %.2f ms per octave per frame (%.1f ns per pixel per octave)\n", slope,
                    slope * 1e6 / firstPixels);
    }
    return 0;
} catch (const Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
}
