#pragma once
// mucosa view: a window (GLFW; needs an X server, e.g. Xvfb) flying through
// the scene, with Dear ImGui panels for the mode and every registry
// parameter, applied live, and the frame rate.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include <mucosa/scene/scene.hpp>

namespace mucosa::render {

struct ViewerOptions {
    int width = 1280, height = 800;
    bool autoplay = true;                             // fly along the camera path; any navigation key pauses
    int pathFrames = 900;                             // poses along the path for auto-play (one per displayed frame)
    int maxFrames = 0;                                // > 0: close after this many frames (scripted runs, tests)
    std::optional<std::filesystem::path> screenshot;  // written after the last frame (with the panels)
    bool vsync = true;
};

struct ViewerReport {
    int frames = 0;
    double meanFps = 0;
    std::string glRenderer;
};

// Runs until the window is closed (or maxFrames). Throws GraphicsError if no
// window can be opened (no DISPLAY, no OpenGL 3.3).
ViewerReport runViewer(scene::Scene scene, scene::SceneAssets assets, const ViewerOptions& options);

// Key and mouse bindings, for --help.
std::string viewerControls();

}  // namespace mucosa::render
