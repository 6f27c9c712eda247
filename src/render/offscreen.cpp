#include <mucosa/render/offscreen.hpp>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "render/gl.hpp"

namespace mucosa::render {

OffscreenSession::OffscreenSession(const scene::Scene& scene, const scene::SceneAssets& assets, int width, int height)
    : scene_(scene), width_(width), height_(height) {
    context_ = std::make_unique<HeadlessContext>();
    renderer_ = std::make_unique<Renderer>();
    framebuffer_ = std::make_unique<Framebuffer>(width, height);
    rendererName_ = glRenderer();
    renderer_->setMesh(assets.mesh);
    if (!assets.diffuse.empty())
        renderer_->setTexture(TextureSlot::Diffuse, assets.diffuse, scene.filter, shading::Wrap::Repeat);
    if (!assets.reflectanceMap.empty())
        renderer_->setTexture(TextureSlot::Reflectance, assets.reflectanceMap, scene.filter, shading::Wrap::Repeat);
}

OffscreenSession::~OffscreenSession() {
    context_->makeCurrent();
    framebuffer_.reset();
    deep_.reset();
    renderer_.reset();
}

void OffscreenSession::setReflectanceMap(const image::Image8& map) {
    renderer_->setTexture(TextureSlot::Reflectance, map, scene_.filter, shading::Wrap::Repeat);
}

void OffscreenSession::setDiffuse(const image::Image8& texture) {
    renderer_->setTexture(TextureSlot::Diffuse, texture, scene_.filter, shading::Wrap::Repeat);
}

void OffscreenSession::draw(const camera::Pose& pose, shading::Mode mode) {
    shading::FrameSetup f = scene::frameSetup(scene_, pose, width_, height_);
    f.mode = mode;
    framebuffer_->bind();
    renderer_->draw(f);
}

void OffscreenSession::draw(const shading::FrameSetup& frame) {
    framebuffer_->bind();
    renderer_->draw(frame);
}

void OffscreenSession::finish() {
    glFinish();
}

image::Image8 OffscreenSession::render(const camera::Pose& pose, std::optional<shading::Mode> mode,
                                       const shading::ParamSet* params) {
    shading::FrameSetup f = scene::frameSetup(scene_, pose, width_, height_);
    if (mode) f.mode = *mode;
    if (params) f.params = *params;
    framebuffer_->bind();
    renderer_->draw(f);
    return framebuffer_->readRgb();
}

image::Image8 OffscreenSession::renderFrame(const shading::FrameSetup& frame) {
    if (frame.width != framebuffer_->width() || frame.height != framebuffer_->height()) {
        framebuffer_.reset();
        framebuffer_ = std::make_unique<Framebuffer>(frame.width, frame.height);
    }
    framebuffer_->bind();
    renderer_->draw(frame);
    image::Image8 img = framebuffer_->readRgb();
    if (frame.width != width_ || frame.height != height_) {
        framebuffer_.reset();
        framebuffer_ = std::make_unique<Framebuffer>(width_, height_);
    }
    return img;
}

image::ImageF OffscreenSession::renderFrameFloat(const shading::FrameSetup& frame) {
    if (!deep_ || deep_->width() != frame.width || deep_->height() != frame.height) {
        deep_.reset();
        deep_ = std::make_unique<Framebuffer>(frame.width, frame.height, ColorFormat::Rgba32F);
    }
    deep_->bind();
    renderer_->draw(frame);
    return deep_->readRgbLinear();
}

image::Image16 OffscreenSession::renderFrame16(const shading::FrameSetup& frame) {
    const image::ImageF v = renderFrameFloat(frame);
    image::Image16 out(v.width(), v.height(), 3);
    for (std::size_t i = 0; i < v.size(); ++i)
        out.data()[i] = static_cast<std::uint16_t>(std::lround(std::clamp(v.data()[i], 0.0f, 1.0f) * 65535.0f));
    return out;
}

std::filesystem::path frameName(const std::filesystem::path& output, int index) {
    std::filesystem::path p = output;
    const std::string ext = output.has_extension() ? output.extension().string() : ".png";
    p.replace_filename(fmt::format("{}_{:04d}{}", output.stem().string(), index, ext));
    return p;
}

}  // namespace mucosa::render
