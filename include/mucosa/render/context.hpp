#pragma once
// OpenGL 3.3 core contexts and render targets. Headless: EGL through
// eglGetPlatformDisplay, Mesa's surfaceless platform first, then each EGL
// device; no X server and no GPU needed (Mesa llvmpipe), unchanged on a GPU.
#include <string>

#include <mucosa/core/error.hpp>
#include <mucosa/image/image.hpp>

namespace mucosa::render {

// No usable OpenGL (no EGL platform, no 3.3 core context, a shader that does
// not compile, a framebuffer that is incomplete).
class GraphicsError : public Error {
public:
    using Error::Error;
};

// An EGL display + OpenGL 3.3 core context, current on the creating thread.
class HeadlessContext {
public:
    HeadlessContext();  // throws GraphicsError saying which step failed
    ~HeadlessContext();
    HeadlessContext(const HeadlessContext&) = delete;
    HeadlessContext& operator=(const HeadlessContext&) = delete;

    void makeCurrent();
    const std::string& platform() const noexcept { return platform_; }  // "surfaceless" or "device"

private:
    void* display_ = nullptr;
    void* context_ = nullptr;
    std::string platform_;
};

// GL_RENDERER, GL_VERSION of the current context.
std::string glRenderer();
std::string glVersion();

// An offscreen colour + depth (24-bit) framebuffer. Colour is RGBA8 (what
// a display shows: values clamp to [0, 1]) or RGBA16F (linear radiance,
// unclamped up to the largest half float: for callers that develop the
// frame themselves, as `mucosa categories` does with the video's response).
// Rgba32F: a frame read back without rounding (16-bit PNGs).
enum class ColorFormat { Rgba8, Rgba16F, Rgba32F };
class Framebuffer {
public:
    Framebuffer(int width, int height, ColorFormat format = ColorFormat::Rgba8);  // throws GraphicsError if incomplete
    ~Framebuffer();
    Framebuffer(const Framebuffer&) = delete;
    Framebuffer& operator=(const Framebuffer&) = delete;

    void bind();  // as the draw and read framebuffer, viewport = whole
    int width() const noexcept { return width_; }
    int height() const noexcept { return height_; }
    // RGB8, first row = top of the image (rows flipped from OpenGL's bottom-up).
    image::Image8 readRgb();
    // RGB as floats, first row = top (RGBA8: the stored value / 255).
    image::ImageF readRgbLinear();

private:
    int width_, height_;
    unsigned fbo_ = 0, color_ = 0, depth_ = 0;
};

}  // namespace mucosa::render
