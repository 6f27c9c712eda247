#pragma once
// The real-time renderer: one GLSL program per shading mode, compiled when the
// renderer is made (so switching modes costs nothing), and for the procedural
// mode one program per specialisation (octaves, noise space, tileable,
// turbulence, headlight), compiled the first time a frame asks for it; the
// mesh in one vertex buffer, textures uploaded once. Works in any current OpenGL 3.3 core context
// (HeadlessContext or a GLFW window).
#include <memory>

#include <mucosa/image/image.hpp>
#include <mucosa/mesh/mesh.hpp>
#include <mucosa/shading/reference.hpp>

namespace mucosa::render {

enum class TextureSlot { Diffuse, Reflectance, Highlight };

// The cube-face size at which a face's centre texel spans the smallest angle
// between neighbouring rays of `rays` (Renderer::setLensRays), 16..4096.
int lensFaceSize(const image::ImageF& rays);

// Through a lens whose every ray lies within kOneFaceMaxTan of the axis
// (max(|x|, |y|) / z <= 2.75: 70 degrees along the image's axes), the
// renderer draws one wide perspective face, in one pass as a pinhole frame,
// with kOneFaceDensity of a texel per output pixel where the rays are
// densest (the frame is softer than that anyway: camera.softness_px); wider
// lenses go through a cube map. A face clips at the near plane along the
// optical axis, the cube's along each face's own axis
// (dataset::NearClip).
inline constexpr double kOneFaceMaxTan = 2.75;
inline constexpr double kOneFaceDensity = 0.6;
bool drawnInOneFace(const image::ImageF& rays);

// Removes the rays of the pixels the scope's field-of-view mask
// (camera.mask, camera.mask_radius of `params`) blacks out, keeping those
// within the optics' point-spread reach of the field: they are never seen,
// and a 120-degree fisheye's corners would otherwise need a cube map.
void clipRaysToMask(image::ImageF& rays, const shading::ParamSet& params);

class Renderer {
public:
    Renderer();  // needs a current context; throws GraphicsError if a shader fails
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    // Uploads positions and normals (required: throws InputError("mesh", ...)),
    // and tangents and uvs when the mesh has both. Without them only the modes
    // that need no texture coordinates render (shading::ModeInfo::uvs); draw()
    // refuses the others.
    void setMesh(const mesh::Mesh& mesh);
    // Uploads an image (rows in file order: first row at v = 1). Without a
    // Highlight texture the renderer makes one from the current shininess
    // (shading::highlightSphereMap(shading::kHighlightTextureSize, shininess)).
    void setTexture(TextureSlot slot, const image::Image8& img, shading::Filter filter, shading::Wrap wrap);
    void clearTexture(TextureSlot slot);  // back to the default (white / flat / generated)

    // Clears the bound framebuffer to black and draws the mesh; the viewport
    // must already be set (Framebuffer::bind does).
    void draw(const shading::FrameSetup& frame);

    // Rendering through a lens (fisheye, omnidirectional: docs/datasets.md,
    // "Lens models"). `rays` holds every output pixel's ray: a unit vector in
    // the camera's frame with OpenCV axes (x right, y down, z forward; row 0
    // the image's top row), or (0, 0, 0) where the lens sees nothing (black).
    // draw() then renders one wide face along the camera's axis when every
    // ray lies within kOneFaceMaxTan of it (drawnInOneFace), else the faces of
    // a cube map around the camera that the rays reach, `faceSize` pixels
    // square (0: a texel per output pixel where the rays are densest,
    // lensFaceSize(rays), times kOneFaceDensity for the one face), and
    // resamples it along each ray (bilinear, seamless across a cube's faces);
    // the camera (exposure, noise, mask) develops the result as it does a
    // pinhole frame. The frame's
    // projection matrix gives only the near and far planes; its size must be
    // the rays'. Empty `rays`: back to the pinhole. Throws InputError for
    // rays that are not 3-channel, ResourceError before allocating what does
    // not fit.
    void setLensRays(const image::ImageF& rays, int faceSize = 0);
    int cubeFaceSize() const noexcept;  // the lens's faces (0 without a lens)

    // The linear exposure factor the camera developed the last frame with
    // (after auto-exposure); FrameSetup::fixedExposure develops another
    // version of it with the same.
    float lastExposure() const noexcept;

    std::size_t triangleCount() const noexcept;
    // Triangles in the chunks the last draw() did not cull (frustum culling).
    std::size_t lastDrawnTriangles() const noexcept;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace mucosa::render
