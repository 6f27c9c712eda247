// bench_render [scene.json] [--frames N] [--sizes 640x480,1280x1024] [--modes noise,vertex-phong,...]
// Frames per second of each shading mode, headless: every frame is drawn and
// finished with glFinish (no read-back), along the scene's camera path, after
// a warm-up. Shader compilation and texture upload happen before timing.
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
#include <mucosa/render/scene.hpp>

using namespace mucosa;

namespace {

constexpr int kRounds = 5;

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

int main(int argc, char** argv) try {
    std::string sceneFile;
    int frames = 40;
    std::vector<std::string> sizes = {"640x480", "1280x1024"};
    std::vector<std::string> modes = {"noise", "vertex-phong", "multitexture", "diffuse"};
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--frames" && i + 1 < argc)
            frames = std::atoi(argv[++i]);
        else if (a == "--sizes" && i + 1 < argc)
            sizes = split(argv[++i]);
        else if (a == "--modes" && i + 1 < argc)
            modes = split(argv[++i]);
        else if (a == "--help") {
            std::puts("bench_render [scene.json] [--frames N] [--sizes WxH,...] [--modes m,...]");
            return 0;
        } else
            sceneFile = a;
    }
    const render::Scene scene = sceneFile.empty() ? render::defaultScene() : render::loadScene(sceneFile);
    const render::SceneAssets assets = render::loadAssets(scene);
    for (const auto& n : assets.notes) std::printf("%s\n", n.c_str());
    const std::vector<camera::Pose> poses = render::cameraPoses(scene, assets, frames);
    std::map<std::string, std::map<std::string, double>> fps;
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
                const shading::Mode mode = shading::parseMode(m, "--modes");
                for (int i = 0; i < 2; ++i) session.draw(poses[static_cast<std::size_t>(i) % poses.size()], mode);
                session.finish();
                const auto t0 = std::chrono::steady_clock::now();
                std::size_t drawn = 0;
                for (int i = 0; i < frames; ++i) {
                    session.draw(poses[static_cast<std::size_t>(i)], mode);
                    session.finish();
                    drawn += session.renderer().lastDrawnTriangles();
                }
                const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                fps[size][m] = std::max(fps[size][m], frames / s);
                drawnTriangles = drawn / static_cast<std::size_t>(frames);
                std::fprintf(stderr, "round %d %s %s: %.1f fps\n", round + 1, size.c_str(), m.c_str(), frames / s);
            }
    }
    std::printf("GL_RENDERER: %s\n", rendererName.c_str());
    std::printf(
        "mesh: %zu triangles (%zu drawn per frame on average after frustum culling), %d frames per "
        "measurement along the camera path, best of %d rounds\n\n",
        assets.mesh.triangleCount(), drawnTriangles, frames, kRounds);
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
        std::printf("| cost ratio noise / vertex-phong |");
        for (const auto& s : sizes) std::printf(" %.2f |", fps[s]["vertex-phong"] / fps[s]["noise"]);
        std::printf("\n");
    }
    return 0;
} catch (const Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
}
