#include <mucosa/render/context.hpp>

#include <cstring>
#include <vector>

#include <fmt/format.h>

#include "render/gl.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

namespace mucosa::render {

namespace {

std::string eglErrorName(EGLint e) {
    switch (e) {
        case EGL_SUCCESS:
            return "EGL_SUCCESS";
        case EGL_NOT_INITIALIZED:
            return "EGL_NOT_INITIALIZED";
        case EGL_BAD_ACCESS:
            return "EGL_BAD_ACCESS";
        case EGL_BAD_ALLOC:
            return "EGL_BAD_ALLOC";
        case EGL_BAD_ATTRIBUTE:
            return "EGL_BAD_ATTRIBUTE";
        case EGL_BAD_CONFIG:
            return "EGL_BAD_CONFIG";
        case EGL_BAD_CONTEXT:
            return "EGL_BAD_CONTEXT";
        case EGL_BAD_DISPLAY:
            return "EGL_BAD_DISPLAY";
        case EGL_BAD_MATCH:
            return "EGL_BAD_MATCH";
        case EGL_BAD_PARAMETER:
            return "EGL_BAD_PARAMETER";
        default:
            return fmt::format("EGL error 0x{:x}", e);
    }
}

bool hasExtension(const char* list, const char* name) {
    if (list == nullptr) return false;
    const std::size_t n = std::strlen(name);
    for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    return false;
}

// Initialises `d`; returns false (and terminates it) on failure.
bool initialise(EGLDisplay d) {
    if (d == EGL_NO_DISPLAY) return false;
    EGLint major = 0, minor = 0;
    if (!eglInitialize(d, &major, &minor)) return false;
    return true;
}

EGLContext createCoreContext(EGLDisplay d, std::string& why) {
    if (!eglBindAPI(EGL_OPENGL_API)) {
        why = "eglBindAPI(EGL_OPENGL_API) failed: " + eglErrorName(eglGetError());
        return EGL_NO_CONTEXT;
    }
    const EGLint configAttribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint count = 0;
    const bool noConfig = hasExtension(eglQueryString(d, EGL_EXTENSIONS), "EGL_KHR_no_config_context");
    if (!eglChooseConfig(d, configAttribs, &config, 1, &count) || count < 1) {
        if (!noConfig) {
            why = "no EGL config supports OpenGL";
            return EGL_NO_CONTEXT;
        }
        config = EGL_NO_CONFIG_KHR;
    }
    const EGLint contextAttribs[] = {
        EGL_CONTEXT_MAJOR_VERSION,           3,       EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
        EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    EGLContext c = eglCreateContext(d, config, EGL_NO_CONTEXT, contextAttribs);
    if (c == EGL_NO_CONTEXT) why = "eglCreateContext(OpenGL 3.3 core) failed: " + eglErrorName(eglGetError());
    return c;
}

}  // namespace

HeadlessContext::HeadlessContext() {
    const char* clientExt = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (clientExt == nullptr) throw GraphicsError("EGL", "", "no EGL client extensions (is libEGL installed?)");
    std::string why = "no EGL platform could be initialised";
    EGLDisplay d = EGL_NO_DISPLAY;
    EGLContext c = EGL_NO_CONTEXT;
    auto attempt = [&](EGLDisplay candidate, const char* name) {
        if (!initialise(candidate)) return false;
        c = createCoreContext(candidate, why);
        if (c == EGL_NO_CONTEXT) return false;
        d = candidate;
        platform_ = name;
        return true;
    };
    bool ok = false;
    if (hasExtension(clientExt, "EGL_MESA_platform_surfaceless"))
        ok = attempt(eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr), "surfaceless");
    if (!ok && hasExtension(clientExt, "EGL_EXT_platform_device")) {
        auto queryDevices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
        if (queryDevices != nullptr) {
            EGLDeviceEXT devices[16];
            EGLint n = 0;
            if (queryDevices(16, devices, &n))
                for (EGLint i = 0; i < n && !ok; ++i)
                    ok = attempt(eglGetPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr), "device");
        }
    }
    if (!ok) throw GraphicsError("EGL", "", why);
    display_ = d;
    context_ = c;
    makeCurrent();
}

HeadlessContext::~HeadlessContext() {
    // The display is not terminated: EGL hands every caller the same display
    // for a platform, and terminating it would break other live contexts.
    auto d = static_cast<EGLDisplay>(display_);
    eglMakeCurrent(d, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(d, static_cast<EGLContext>(context_));
}

void HeadlessContext::makeCurrent() {
    if (!eglMakeCurrent(static_cast<EGLDisplay>(display_), EGL_NO_SURFACE, EGL_NO_SURFACE,
                        static_cast<EGLContext>(context_)))
        throw GraphicsError("EGL", "", "eglMakeCurrent without a surface failed: " + eglErrorName(eglGetError()));
}

std::string glRenderer() {
    const auto* s = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    return s ? s : "";
}

std::string glVersion() {
    const auto* s = reinterpret_cast<const char*>(glGetString(GL_VERSION));
    return s ? s : "";
}

Framebuffer::Framebuffer(int width, int height, ColorFormat format) : width_(width), height_(height) {
    if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
        throw InputError("size", "", fmt::format("{}x{} is not a valid frame size (1..16384)", width, height));
    glGenFramebuffers(1, &fbo_);
    glGenRenderbuffers(1, &color_);
    glGenRenderbuffers(1, &depth_);
    glBindRenderbuffer(GL_RENDERBUFFER, color_);
    const GLenum internal = format == ColorFormat::Rgba16F   ? GL_RGBA16F
                            : format == ColorFormat::Rgba32F ? GL_RGBA32F
                                                             : GL_RGBA8;
    glRenderbufferStorage(GL_RENDERBUFFER, internal, width, height);
    glBindRenderbuffer(GL_RENDERBUFFER, depth_);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
    const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        throw GraphicsError("framebuffer", "", fmt::format("incomplete (status 0x{:x})", status));
}

Framebuffer::~Framebuffer() {
    glDeleteFramebuffers(1, &fbo_);
    glDeleteRenderbuffers(1, &color_);
    glDeleteRenderbuffers(1, &depth_);
}

void Framebuffer::bind() {
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glViewport(0, 0, width_, height_);
}

image::Image8 Framebuffer::readRgb() {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
    std::vector<std::uint8_t> rgba(static_cast<std::size_t>(width_) * height_ * 4);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    image::Image8 out(width_, height_, 3);
    for (int y = 0; y < height_; ++y) {
        const std::uint8_t* src = rgba.data() + static_cast<std::size_t>(height_ - 1 - y) * width_ * 4;
        std::uint8_t* dst = out.row(y);
        for (int x = 0; x < width_; ++x) {
            dst[3 * x] = src[4 * x];
            dst[3 * x + 1] = src[4 * x + 1];
            dst[3 * x + 2] = src[4 * x + 2];
        }
    }
    return out;
}

image::ImageF Framebuffer::readRgbLinear() {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
    std::vector<float> rgba(static_cast<std::size_t>(width_) * height_ * 4);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, width_, height_, GL_RGBA, GL_FLOAT, rgba.data());
    image::ImageF out(width_, height_, 3);
    for (int y = 0; y < height_; ++y) {
        const float* src = rgba.data() + static_cast<std::size_t>(height_ - 1 - y) * width_ * 4;
        for (int x = 0; x < width_; ++x)
            for (int c = 0; c < 3; ++c) out.at(x, y, c) = src[4 * x + c];
    }
    return out;
}

}  // namespace mucosa::render
