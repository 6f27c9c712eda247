#pragma once
// Headless rendering of a scene: a context, the renderer and a framebuffer,
// set up once (shader compile and texture upload are not on the per-frame
// path), then any number of frames.
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <mucosa/camera/camera.hpp>
#include <mucosa/image/image.hpp>
#include <mucosa/render/context.hpp>
#include <mucosa/render/renderer.hpp>
#include <mucosa/scene/scene.hpp>

namespace mucosa::render {

class OffscreenSession {
public:
    // Creates a HeadlessContext (throws GraphicsError without EGL), compiles
    // the shaders, uploads the mesh and textures.
    OffscreenSession(const scene::Scene& scene, const scene::SceneAssets& assets, int width, int height);
    ~OffscreenSession();

    // One frame; `mode`/`params` default to the scene's.
    image::Image8 render(const camera::Pose& pose, std::optional<shading::Mode> mode = std::nullopt,
                         const shading::ParamSet* params = nullptr);
    // One frame of any setup (render::frameSetup(scene, ...) with changes:
    // a jittered projection, another size, anti-aliasing off, ...).
    image::Image8 renderFrame(const shading::FrameSetup& frame);
    // The same frame at 16 bits per channel: drawn into a float target and
    // rounded once (v x 65535), where renderFrame's 8-bit target rounds to
    // v x 255 (the two agree to half an 8-bit step).
    image::Image16 renderFrame16(const shading::FrameSetup& frame);
    // The same frame as floats, unrounded (the developed signal in [0, 1]).
    image::ImageF renderFrameFloat(const shading::FrameSetup& frame);
    // Draws without reading back (benchmarks call glFinish through finish()).
    void draw(const camera::Pose& pose, shading::Mode mode);
    void draw(const shading::FrameSetup& frame);  // at the session's size
    void finish();

    void setReflectanceMap(const image::Image8& map);
    void setDiffuse(const image::Image8& texture);  // the subject texture (sRGB-encoded)
    Renderer& renderer() noexcept { return *renderer_; }
    const std::string& glRendererName() const noexcept { return rendererName_; }
    int width() const noexcept { return width_; }
    int height() const noexcept { return height_; }

private:
    const scene::Scene& scene_;
    int width_, height_;
    std::unique_ptr<HeadlessContext> context_;
    std::unique_ptr<Renderer> renderer_;
    std::unique_ptr<Framebuffer> framebuffer_;
    std::unique_ptr<Framebuffer> deep_;  // renderFrame16's float target, made on first use
    std::string rendererName_;
};

// Output name of frame `index` of a sequence: out.png -> out_0012.png.
std::filesystem::path frameName(const std::filesystem::path& output, int index);

// The paper's Figures 2 and 3 as one labelled picture: the same views in
// every mode (columns: noise, procedural, vertex-phong, multitexture,
// diffuse), a row varying the reflectance map's noise frequency, specular
// anti-aliasing off/on for the map and the procedural path, and a coarse
// surface patch (where the per-vertex baselines facet).
struct CompareOptions {
    int tileWidth = 400, tileHeight = 300;
    std::vector<double> frequencies = {4, 8, 16, 32};
    int views = 2;  // views along the camera path
    std::function<void(int done, int total)> progress;
};
image::Image8 compareSheet(const scene::Scene& scene, const scene::SceneAssets& assets,
                           const CompareOptions& options = {});

// The comparison sheet of the built-in default scene (the phantom, 'bronchial'
// preset), written atomically to `png`: what `mucosa demo` adds to ./out/.
void writeDefaultCompareSheet(const std::filesystem::path& png, int threads = 0);

// Highlight shape statistics (are the highlights irregular, as the paper says they should be?): pixels
// whose smallest channel is >= threshold (white highlights on pink tissue),
// 8-connected components of >= minArea pixels, each with perimeter (pixel
// edges between inside and outside) and P^2/A (16 for a square, ~4 pi * 1.1
// for a digital disc; larger = more ragged).
struct HighlightStats {
    int components = 0;
    double totalArea = 0;
    double meanIsoperimetric = 0;      // mean P^2/A over components
    double weightedIsoperimetric = 0;  // area-weighted mean P^2/A
};
HighlightStats highlightStats(const image::Image8& rgb, int threshold = 200, int minArea = 3);

// Draws `text` (ASCII) into an RGB image at (x, y) (top-left), scale 1 = 8 px tall glyphs.
void drawText(image::Image8& img, int x, int y, const std::string& text, std::array<std::uint8_t, 3> color,
              int scale = 2);

}  // namespace mucosa::render
