#include <mucosa/render/renderer.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/reflectance/specular_mips.hpp>
#include <mucosa/render/context.hpp>
#include <mucosa/shading/scatter.hpp>

#include "render/embedded_shaders.hpp"
#include "render/gl.hpp"
#include "render/procedural_uniforms.hpp"
#include "render/shader.hpp"
#include "render/uniforms.hpp"
#include "shading/glsl.hpp"

namespace mucosa::render {

namespace {

struct Program {
    GLuint id = 0;
    UniformBlock frame, material;  // uFrame, uMaterial (render/uniforms.hpp)
    ProceduralUniforms procedural;
    std::uint64_t permutationVersion = 0;  // Impl's version of the tables in uPerm, uPermSlice; 0: none yet
    GLint split = -1;                      // uSplit: body light and specular apart, for the scattering
};

// Texture units of the samplers.
constexpr std::array<const char*, 3> kSamplers = {"uDiffuse", "uReflectance", "uHighlight"};  // TextureSlot order

// `defines`: extra preprocessor lines (the procedural mode's specialisation).
Program link(int mode, const std::string& defines = "") {
    const std::string header = fmt::format("#version 330 core\n#define MUCOSA_MODE {}\n", mode) + defines;
    const std::string common = std::string(permutationPrelude()) + std::string(shaderSource("camera.glsl")) +
                               std::string(shaderSource("procedural_noise.glsl")) +
                               std::string(shaderSource("common_shading.glsl"));
    const std::string name =
        fmt::format("surface_tissue (mode {})", shading::modeName(static_cast<shading::Mode>(mode)));
    Program p;
    p.id = linkProgram(header + common + varyingDeclarations(true) + std::string(shaderSource("surface_tissue.vert")),
                       header + common + varyingDeclarations(false) + std::string(shaderSource("surface_tissue.frag")),
                       name);
    checkActiveUniforms(p.id, name);
    p.frame = UniformBlock(p.id, frameUniforms());
    p.material = UniformBlock(p.id, materialUniforms());
    p.procedural = ProceduralUniforms(p.id);
    p.split = glGetUniformLocation(p.id, "uSplit");
    glUseProgram(p.id);
    for (std::size_t unit = 0; unit < kSamplers.size(); ++unit)
        glUniform1i(glGetUniformLocation(p.id, kSamplers[unit]), static_cast<GLint>(unit));
    return p;
}

// The camera's post pass (camera_post.frag): reads the HDR target, writes
// the displayed frame.
struct PostProgram {
    GLuint id = 0;
    UniformBlock camera;
};

// A full-frame pass of the camera (camera_post.vert + `frag`, after
// camera.glsl): the post pass (camera_post.frag, reads the HDR target from
// unit 0) or the mask pass (camera_mask.frag, the field stop as a depth
// occluder).
PostProgram linkCameraPass(const char* frag, const char* name) {
    const std::string header = "#version 330 core\n" + std::string(shaderSource("camera.glsl"));
    PostProgram p;
    p.id = linkProgram("#version 330 core\n" + std::string(shaderSource("camera_post.vert")),
                       header + std::string(shaderSource(frag)), name);
    checkActiveUniforms(p.id, name);
    p.camera = UniformBlock(p.id, cameraUniforms());
    glUseProgram(p.id);
    const GLint hdr = glGetUniformLocation(p.id, "uHdr");
    if (hdr >= 0) glUniform1i(hdr, 0);
    return p;
}

// A texture of w x h texels sampled texel by texel (nearest, no mips): the
// targets the passes read with texelFetch.
GLuint makeTexelTexture(GLint internalFormat, GLenum format, GLenum type, int w, int h) {
    GLuint id = 0;
    glGenTextures(1, &id);
    glBindTexture(GL_TEXTURE_2D, id);
    glTexImage2D(GL_TEXTURE_2D, 0, internalFormat, w, h, 0, format, type, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    return id;
}

// A depth buffer the scattering passes can read (scatter.frag): 24 bits.
GLuint makeDepthTexture(int w, int h) {
    return makeTexelTexture(GL_DEPTH_COMPONENT24, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, w, h);
}

// Linear radiance in half floats (RGBA16F: renderable on every GL 3.3
// implementation).
GLuint makeHalfTexture(int w, int h) {
    return makeTexelTexture(GL_RGBA16F, GL_RGBA, GL_FLOAT, w, h);
}

// The surface pass's target for the photographic modes: linear radiance in
// half floats (RGBA16F: renderable on every GL 3.3 implementation), a depth
// texture, and the auto-exposure meter's kMeterGrid^2 target.
struct HdrTarget {
    GLuint fbo = 0, color = 0, depth = 0;
    GLuint meterFbo = 0, meterColor = 0;
    int width = 0, height = 0;

    void ensure(int w, int h) {
        if (fbo != 0 && w == width && h == height) return;
        release();
        // Half-float RGBA and 24-bit depth per pixel (system memory on a
        // software rasteriser): refused before allocating if it cannot fit.
        requireMemory(saturatingMul(saturatingMul(static_cast<std::uint64_t>(w), static_cast<std::uint64_t>(h)), 12),
                      "the camera's HDR target");
        glGenFramebuffers(1, &fbo);
        color = makeHalfTexture(w, h);
        depth = makeDepthTexture(w, h);
        glBindFramebuffer(GL_FRAMEBUFFER, fbo);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color, 0);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth, 0);
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            throw GraphicsError("framebuffer", "", "the HDR target (RGBA16F) is incomplete");
        glGenFramebuffers(1, &meterFbo);
        glGenTextures(1, &meterColor);
        glBindTexture(GL_TEXTURE_2D, meterColor);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, shading::kMeterGrid, shading::kMeterGrid, 0, GL_RGBA, GL_FLOAT,
                     nullptr);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
        glBindFramebuffer(GL_FRAMEBUFFER, meterFbo);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, meterColor, 0);
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            throw GraphicsError("framebuffer", "", "the auto-exposure meter (RGBA32F) is incomplete");
        width = w;
        height = h;
    }
    void release() {
        if (fbo != 0) glDeleteFramebuffers(1, &fbo);
        if (meterFbo != 0) glDeleteFramebuffers(1, &meterFbo);
        if (color != 0) glDeleteTextures(1, &color);
        if (meterColor != 0) glDeleteTextures(1, &meterColor);
        if (depth != 0) glDeleteTextures(1, &depth);
        fbo = color = depth = meterFbo = meterColor = 0;
        width = height = 0;
    }
};

// The sub-surface scattering's passes (scatter.frag): the program, the
// kernel of the distances it last served, its targets (grown to the largest
// image they have served): the two half-size images (RGBA32F: rgb and the
// eye depth) and a copy of the image the passes read (RGBA16F), and the
// framebuffers. The last pass writes through `finalFbo`, which has no depth,
// so the depth texture the passes read is never attached where they draw.
struct ScatterPass {
    GLuint program = 0;
    GLuint halfA = 0, halfB = 0, kept = 0;
    GLuint fboA = 0, fboB = 0, keptFbo = 0, readFbo = 0, finalFbo = 0;
    int width = 0, height = 0;  // full size
    std::array<float, 3> distances{-1.0f, -1.0f, -1.0f};
    GLint rect = -1, pass = -1, focal = -1, projection = -1, share = -1;

    void link() {
        program = linkProgram("#version 330 core\n" + std::string(shaderSource("camera_post.vert")),
                              "#version 330 core\n" + std::string(shaderSource("scatter.glsl")) +
                                  std::string(shaderSource("scatter.frag")),
                              "scatter");
        glUseProgram(program);
        glUniform1i(glGetUniformLocation(program, "uSource"), 0);
        glUniform1i(glGetUniformLocation(program, "uDepth"), 1);
        glUniform1i(glGetUniformLocation(program, "uHalf"), 2);
        rect = glGetUniformLocation(program, "uRect");
        pass = glGetUniformLocation(program, "uPass");
        focal = glGetUniformLocation(program, "uFocalPx");
        projection = glGetUniformLocation(program, "uProjection");
        share = glGetUniformLocation(program, "uShare");
        for (GLuint* f : {&fboA, &fboB, &keptFbo, &readFbo, &finalFbo}) glGenFramebuffers(1, f);
    }
    void setKernel(const std::array<float, 3>& d) {
        if (d == distances) return;
        const shading::ScatterKernel k = shading::scatterKernel(d);
        glUseProgram(program);
        glUniform1fv(glGetUniformLocation(program, "uOffsetMm"), shading::kScatterTaps, k.offsetMm.data());
        glUniform3fv(glGetUniformLocation(program, "uWeight"), shading::kScatterTaps, k.weight[0].data());
        distances = d;
    }
    static void attach(GLuint fbo, GLuint tex, const char* what) {
        glBindFramebuffer(GL_FRAMEBUFFER, fbo);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex, 0);
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            throw GraphicsError("framebuffer", "", fmt::format("the scattering's {} is incomplete", what));
    }
    void ensure(int w, int h) {
        if (kept != 0 && w <= width && h <= height) return;
        for (GLuint* t : {&halfA, &halfB, &kept})
            if (*t != 0) glDeleteTextures(1, t), *t = 0;
        width = std::max(w, width), height = std::max(h, height);
        const std::uint64_t pixels = static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
        // The copy (8 bytes a pixel) and the two half-size RGBA32F images (16 bytes a quarter pixel each).
        requireMemory(saturatingMul(pixels, 8 + 2 * 16 / 4), "the scattering's targets");
        const int hw = (width + 1) / 2, hh = (height + 1) / 2;
        halfA = makeTexelTexture(GL_RGBA32F, GL_RGBA, GL_FLOAT, hw, hh);
        halfB = makeTexelTexture(GL_RGBA32F, GL_RGBA, GL_FLOAT, hw, hh);
        kept = makeHalfTexture(width, height);
        attach(fboA, halfA, "half-size target");
        attach(fboB, halfB, "half-size target");
        attach(keptFbo, kept, "copy");
    }
    void release() {
        if (program != 0) glDeleteProgram(program);
        for (GLuint* f : {&fboA, &fboB, &keptFbo, &readFbo, &finalFbo})
            if (*f != 0) glDeleteFramebuffers(1, f), *f = 0;
        for (GLuint* t : {&halfA, &halfB, &kept})
            if (*t != 0) glDeleteTextures(1, t), *t = 0;
        program = 0;
        width = height = 0;
    }
};

// Rendering through a lens (Renderer::setLensRays): the rays as a texture,
// and what the surface pass draws for them (RGBA16F, one depth buffer): one
// wide perspective face when every ray lies within kOneFaceMaxTan of the
// axis (a bronchoscope's 120 degrees: one pass, as a pinhole), else the faces
// of a cube map around the camera that the rays reach.
struct LensTarget {
    GLuint cube = 0, depth = 0, fbo = 0, rays = 0;
    GLuint plane = 0;    // the one wide face (2D texture), or 0: the cube
    GLuint flat = 0;     // the cube's faces when they scatter: drawn here, scattered into the cube (2D texture)
    float planeTan = 0;  // the wide face's half-width and half-height: tan of its half-angle
    int faceSize = 0, width = 0, height = 0;
    std::array<bool, 6> faces{};  // GL_TEXTURE_CUBE_MAP_POSITIVE_X + i drawn
    // Each face's texels the rays (and their bilinear footprint) reach, as
    // x0, y0, x1, y1 (exclusive) in the face's window coordinates: only those
    // are drawn (a 160-degree fisheye uses under half of its side faces).
    std::array<std::array<int, 4>, 6> rects{};
    PostProgram remap;

    bool active() const noexcept { return rays != 0; }
    void release() {
        if (fbo != 0) glDeleteFramebuffers(1, &fbo);
        if (cube != 0) glDeleteTextures(1, &cube);
        if (plane != 0) glDeleteTextures(1, &plane);
        if (flat != 0) glDeleteTextures(1, &flat);
        if (rays != 0) glDeleteTextures(1, &rays);
        if (depth != 0) glDeleteTextures(1, &depth);
        fbo = cube = plane = flat = rays = depth = 0;
        planeTan = 0;
        faceSize = width = height = 0;
        faces = {};
        rects = {};
    }
};

// Where direction d (eye axes) meets cube face i, in the face's texture
// coordinates s, t in [0, 1] (the OpenGL specification's cube-map table: the
// major axis ma and the coordinates sc, tc per face), clamped to the face.
std::pair<float, float> cubeFaceCoordinates(const glm::vec3& d, int face) {
    const int k = face / 2;
    const float ma = std::max(std::abs(d[k]), 1e-12f);
    float sc = 0, tc = 0;
    switch (face) {
        case 0:
            sc = -d.z, tc = -d.y;
            break;  // +x
        case 1:
            sc = d.z, tc = -d.y;
            break;  // -x
        case 2:
            sc = d.x, tc = d.z;
            break;  // +y
        case 3:
            sc = d.x, tc = -d.z;
            break;  // -y
        case 4:
            sc = d.x, tc = -d.y;
            break;  // +z
        default:
            sc = -d.x, tc = -d.y;
            break;  // -z
    }
    return {std::clamp(0.5f * (sc / ma + 1.0f), 0.0f, 1.0f), std::clamp(0.5f * (tc / ma + 1.0f), 0.0f, 1.0f)};
}

// The rotation from the camera's eye axes to cube face i's, in OpenGL's
// cube-map convention (the face's image as samplerCube reads it: +x, -x, +y,
// -y, +z, -z, each seen looking along its axis with these up vectors).
glm::mat4 faceRotation(int face) {
    static const float dirs[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    static const float ups[6][3] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
    const glm::vec3 f(dirs[face][0], dirs[face][1], dirs[face][2]), up(ups[face][0], ups[face][1], ups[face][2]);
    const glm::vec3 side = glm::normalize(glm::cross(f, up)), u = glm::cross(side, f);
    glm::mat4 r(1.0f);
    for (int c = 0; c < 3; ++c) {
        r[c][0] = side[c];
        r[c][1] = u[c];
        r[c][2] = -f[c];
    }
    return r;
}

struct Texture {
    GLuint id = 0;
    bool user = false;
    GLint minFilter = GL_NEAREST;  // as uploaded
    GLint boundMin = GL_NEAREST;   // as set now (anti-aliasing off: level 0 only)
};

// One level of the bound texture, rows flipped: OpenGL's first row is t = 0,
// the bottom, so the file's rows go up bottom-up and v = 1 samples the first
// row (docs/theory.md, "Conventions").
void uploadLevel(GLint level, const image::Image8& img) {
    const int w = img.width(), h = img.height(), ch = img.channels();
    std::vector<std::uint8_t> rows(img.size());
    for (int y = 0; y < h; ++y)
        std::copy(img.row(h - 1 - y), img.row(h - 1 - y) + img.rowStride(),
                  rows.begin() + static_cast<std::ptrdiff_t>(y) * static_cast<std::ptrdiff_t>(img.rowStride()));
    GLenum format = GL_RGB, internal = GL_RGB8;
    if (ch == 1) format = GL_RED, internal = GL_R8;
    if (ch == 2) format = GL_RG, internal = GL_RG8;
    if (ch == 4) format = GL_RGBA, internal = GL_RGBA8;
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, level, static_cast<GLint>(internal), w, h, 0, format, GL_UNSIGNED_BYTE, rows.data());
}

// Returns the minification filter it set.
GLint setSampling(int channels, shading::Filter filter, shading::Wrap wrap) {
    GLint swizzle[] = {GL_RED, GL_GREEN, GL_BLUE, GL_ALPHA};
    if (channels == 3) swizzle[3] = GL_ZERO;  // alpha 0: no slope variance (reflectance maps without mips)
    if (channels == 1) swizzle[1] = swizzle[2] = GL_RED, swizzle[3] = GL_ONE;  // grey, as the reference reads it
    if (channels == 2) swizzle[1] = swizzle[2] = GL_RED, swizzle[3] = GL_GREEN;
    glTexParameteriv(GL_TEXTURE_2D, GL_TEXTURE_SWIZZLE_RGBA, swizzle);
    const GLint wrapMode = wrap == shading::Wrap::Repeat ? GL_REPEAT : GL_CLAMP_TO_EDGE;
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, wrapMode);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, wrapMode);
    GLint minFilter = GL_LINEAR, magFilter = GL_LINEAR;
    if (filter == shading::Filter::Nearest) minFilter = magFilter = GL_NEAREST;
    // Mipmap: bilinear in the nearest mip level, ~20 % cheaper than trilinear
    // on llvmpipe (bench_render) and hardly different to the eye.
    if (filter == shading::Filter::Trilinear) minFilter = GL_LINEAR_MIPMAP_LINEAR;
    if (filter == shading::Filter::Mipmap) minFilter = GL_LINEAR_MIPMAP_NEAREST;
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, minFilter);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, magFilter);
    return minFilter;
}

bool mipmapped(shading::Filter filter) {
    return filter == shading::Filter::Trilinear || filter == shading::Filter::Mipmap;
}

void upload(Texture& t, const image::Image8& img, shading::Filter filter, shading::Wrap wrap) {
    glBindTexture(GL_TEXTURE_2D, t.id);
    uploadLevel(0, img);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 1000);
    if (mipmapped(filter)) glGenerateMipmap(GL_TEXTURE_2D);
    t.minFilter = t.boundMin = setSampling(img.channels(), filter, wrap);
}

// A reflectance map: with mipmaps, the specular anti-aliasing chain (averaged
// normals + slope variance in alpha, reflectance::specularMipChain) instead of
// glGenerateMipmap's averages of encoded colours.
void uploadReflectance(Texture& t, const image::Image8& img, shading::Filter filter, shading::Wrap wrap) {
    if (!mipmapped(filter) || img.channels() < 3) return upload(t, img, filter, wrap);
    const std::vector<image::Image8> chain = reflectance::specularMipChain(img);
    glBindTexture(GL_TEXTURE_2D, t.id);
    for (std::size_t k = 0; k < chain.size(); ++k) uploadLevel(static_cast<GLint>(k), chain[k]);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, static_cast<GLint>(chain.size() - 1));
    t.minFilter = t.boundMin = setSampling(4, filter, wrap);
}

image::Image8 solid(std::uint8_t r, std::uint8_t g, std::uint8_t b) {
    image::Image8 img(1, 1, 3);
    img.at(0, 0, 0) = r;
    img.at(0, 0, 1) = g;
    img.at(0, 0, 2) = b;
    return img;
}

// Triangles are sorted into spatial chunks at upload; each frame draws only the
// chunks whose bounding box meets the view frustum (an airway seen from inside
// shows a small part of the tree). Conservative, so the image is unchanged.
struct Chunk {
    std::array<float, 3> lo, hi;
    GLsizei first = 0, count = 0;  // in indices
};

bool outsideFrustum(const Chunk& c, const glm::mat4& viewProj) {
    int outside[6] = {0, 0, 0, 0, 0, 0};
    for (int k = 0; k < 8; ++k) {
        const glm::vec4 p =
            viewProj * glm::vec4(k & 1 ? c.hi[0] : c.lo[0], k & 2 ? c.hi[1] : c.lo[1], k & 4 ? c.hi[2] : c.lo[2], 1.0f);
        outside[0] += p.x < -p.w;
        outside[1] += p.x > p.w;
        outside[2] += p.y < -p.w;
        outside[3] += p.y > p.w;
        outside[4] += p.z < -p.w;
        outside[5] += p.z > p.w;
    }
    for (int i = 0; i < 6; ++i)
        if (outside[i] == 8) return true;
    return false;
}

std::vector<Chunk> buildChunks(const mesh::Mesh& mesh, std::vector<std::uint32_t>& sorted) {
    std::array<float, 3> lo{1e30f, 1e30f, 1e30f}, hi{-1e30f, -1e30f, -1e30f};
    for (const auto& p : mesh.positions)
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    const std::size_t tris = mesh.triangleCount();
    // About 1000 triangles per chunk, cells as cubes.
    const int cellsWanted = static_cast<int>(std::clamp<std::size_t>(tris / 1000, 1, 8192));
    const float ext[3] = {std::max(hi[0] - lo[0], 1e-3f), std::max(hi[1] - lo[1], 1e-3f),
                          std::max(hi[2] - lo[2], 1e-3f)};
    const float cell = std::cbrt(ext[0] * ext[1] * ext[2] / static_cast<float>(cellsWanted));
    int n[3];
    for (int k = 0; k < 3; ++k) n[k] = std::clamp(static_cast<int>(std::ceil(ext[k] / cell)), 1, 64);
    std::vector<std::uint32_t> cellOf(tris);
    for (std::size_t t = 0; t < tris; ++t) {
        int idx[3];
        for (int k = 0; k < 3; ++k) {
            const float c = (mesh.positions[mesh.indices[3 * t]][k] + mesh.positions[mesh.indices[3 * t + 1]][k] +
                             mesh.positions[mesh.indices[3 * t + 2]][k]) /
                            3.0f;
            idx[k] = std::clamp(static_cast<int>((c - lo[k]) / ext[k] * static_cast<float>(n[k])), 0, n[k] - 1);
        }
        cellOf[t] = static_cast<std::uint32_t>((idx[2] * n[1] + idx[1]) * n[0] + idx[0]);
    }
    std::vector<std::uint32_t> order(tris);
    for (std::size_t t = 0; t < tris; ++t) order[t] = static_cast<std::uint32_t>(t);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return cellOf[a] < cellOf[b]; });
    sorted.resize(mesh.indices.size());
    std::vector<Chunk> chunks;
    for (std::size_t i = 0; i < tris; ++i) {
        const std::uint32_t t = order[i];
        if (chunks.empty() || cellOf[order[i - 1]] != cellOf[t]) {
            Chunk c;
            c.lo = {1e30f, 1e30f, 1e30f};
            c.hi = {-1e30f, -1e30f, -1e30f};
            c.first = static_cast<GLsizei>(3 * i);
            chunks.push_back(c);
        }
        Chunk& c = chunks.back();
        for (int v = 0; v < 3; ++v) {
            const std::uint32_t vi = mesh.indices[3 * t + v];
            sorted[3 * i + v] = vi;
            for (int k = 0; k < 3; ++k)
                c.lo[k] = std::min(c.lo[k], mesh.positions[vi][k]), c.hi[k] = std::max(c.hi[k], mesh.positions[vi][k]);
        }
        c.count += 3;
    }
    return chunks;
}

}  // namespace

struct Renderer::Impl {
    std::array<Program, shading::kModeCount> programs;
    GLuint vao = 0, vbo = 0, ibo = 0;
    GLsizei indexCount = 0;
    std::vector<Chunk> chunks;
    std::vector<const void*> drawOffsets;
    std::vector<GLsizei> drawCounts;
    std::size_t lastDrawnTriangles = 0;
    std::array<Texture, 3> textures;
    bool meshHasUvs = false;
    // The procedural permutation tables of the last seed and z slice, and a
    // version that changes with them.
    PermutationTables permutation;
    std::uint64_t permutationVersion = 0;
    // The map modes that light per pixel, compiled also for a light at the
    // eye (MUCOSA_HEADLIGHT, common_shading.glsl).
    std::array<Program, shading::kModeCount> headlight;
    // The procedural and clearcoat-procedural modes, specialised per (mode,
    // octaves, space, tileable, turbulence, headlight): compiled on first use
    // (procedural_noise.glsl).
    std::map<std::array<int, 6>, Program> procedural;
    float highlightShininess = -1.0f;  // shininess the generated highlight texture was made for
    // The camera: the post pass, its HDR target, and auto-exposure's state
    // along the current camera path (frame 0 starts it afresh).
    PostProgram post, mask;
    GLuint postVao = 0;
    HdrTarget hdr;
    shading::ExposureState exposure;
    LensTarget lens;
    ScatterPass scatter;

    // The phases of draw(), in order.
    Program& programFor(const shading::FrameSetup& frame, const shading::ModeInfo& info);
    void refreshHighlight(const shading::ModeInfo& info, float shininess);
    void uploadUniforms(Program& p, const shading::FrameSetup& frame, const shading::glsl::Frame& f,
                        const shading::glsl::Material& m, const shading::ModeInfo& info);
    void bindTextures(bool specularAA);
    void drawVisibleChunks(const glm::mat4& viewProj);
    void developFrame(const shading::FrameSetup& frame, GLint target, const GLint viewport[4]);
    void occludeOutsideMask(const shading::FrameSetup& frame);
    void scatterImage(const shading::FrameSetup& frame, const glm::mat4& projection, GLuint source, GLuint depth,
                      const int size[2], const std::array<int, 4>& rect, GLenum destTarget, GLuint dest);
    void drawThroughLens(const shading::FrameSetup& frame, Program& program, const shading::glsl::Frame& f,
                         const shading::glsl::Material& m, const shading::ModeInfo& info, bool develop, bool scatters);
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {
    for (int m = 0; m < shading::kModeCount; ++m) impl_->programs[static_cast<std::size_t>(m)] = link(m);
    for (const shading::ModeInfo& m : shading::modes())
        if (m.headlight && !m.procedural)
            impl_->headlight[static_cast<std::size_t>(m.id)] =
                link(static_cast<int>(m.id), "#define MUCOSA_HEADLIGHT 1\n");
    impl_->post = linkCameraPass("camera_post.frag", "camera_post");
    impl_->mask = linkCameraPass("camera_mask.frag", "camera_mask");
    impl_->scatter.link();
    impl_->lens.remap.id =
        linkProgram("#version 330 core\n" + std::string(shaderSource("camera_post.vert")),
                    "#version 330 core\n" + std::string(shaderSource("lens_remap.frag")), "lens_remap");
    glUseProgram(impl_->lens.remap.id);
    glUniform1i(glGetUniformLocation(impl_->lens.remap.id, "uFaces"), 0);
    glUniform1i(glGetUniformLocation(impl_->lens.remap.id, "uRays"), 1);
    glUniform1i(glGetUniformLocation(impl_->lens.remap.id, "uPlane"), 2);
    glGenVertexArrays(1, &impl_->postVao);
    glGenVertexArrays(1, &impl_->vao);
    glGenBuffers(1, &impl_->vbo);
    glGenBuffers(1, &impl_->ibo);
    for (Texture& t : impl_->textures) glGenTextures(1, &t.id);
    clearTexture(TextureSlot::Diffuse);
    clearTexture(TextureSlot::Reflectance);
    clearTexture(TextureSlot::Highlight);
}

Renderer::~Renderer() {
    for (Program& p : impl_->programs) glDeleteProgram(p.id);
    for (Program& p : impl_->headlight) glDeleteProgram(p.id);
    for (auto& [key, p] : impl_->procedural) glDeleteProgram(p.id);
    glDeleteProgram(impl_->post.id);
    glDeleteProgram(impl_->mask.id);
    glDeleteProgram(impl_->lens.remap.id);
    glDeleteVertexArrays(1, &impl_->postVao);
    impl_->hdr.release();
    impl_->lens.release();
    impl_->scatter.release();
    glDeleteVertexArrays(1, &impl_->vao);
    glDeleteBuffers(1, &impl_->vbo);
    glDeleteBuffers(1, &impl_->ibo);
    for (Texture& t : impl_->textures) glDeleteTextures(1, &t.id);
}

std::size_t Renderer::triangleCount() const noexcept {
    return static_cast<std::size_t>(impl_->indexCount / 3);
}
std::size_t Renderer::lastDrawnTriangles() const noexcept {
    return impl_->lastDrawnTriangles;
}

void Renderer::setMesh(const mesh::Mesh& mesh) {
    if (!mesh.hasNormals()) throw InputError("mesh", "", "the renderer needs per-vertex normals");
    // Without texture coordinates (a raw CT surface) the modes that read none
    // still render; draw() refuses the others (shading::modeNeedsUvs).
    const bool uvs = mesh.hasUvs() && mesh.hasTangents();
    constexpr int kStride = 15;  // position 3, normal 3, tangent 4, uv 2, tint 3
    std::vector<float> data(mesh.vertexCount() * kStride);
    for (std::size_t i = 0; i < mesh.vertexCount(); ++i) {
        float* d = data.data() + i * kStride;
        std::copy(mesh.positions[i].begin(), mesh.positions[i].end(), d);
        std::copy(mesh.normals[i].begin(), mesh.normals[i].end(), d + 3);
        const mesh::Vec4 t = uvs ? mesh.tangents[i] : mesh::fallbackTangent(mesh.normals[i]);
        std::copy(t.begin(), t.end(), d + 6);
        if (uvs) std::copy(mesh.uvs[i].begin(), mesh.uvs[i].end(), d + 10);
        const mesh::Vec3 tint = mesh.hasColors() ? mesh.colors[i] : mesh::Vec3{1, 1, 1};
        std::copy(tint.begin(), tint.end(), d + 12);
    }
    glBindVertexArray(impl_->vao);
    glBindBuffer(GL_ARRAY_BUFFER, impl_->vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(), GL_STATIC_DRAW);
    std::vector<std::uint32_t> sorted;
    impl_->chunks = buildChunks(mesh, sorted);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, impl_->ibo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(sorted.size() * sizeof(std::uint32_t)), sorted.data(),
                 GL_STATIC_DRAW);
    const GLsizei stride = kStride * sizeof(float);
    const int sizes[] = {3, 3, 4, 2, 3}, offsets[] = {0, 3, 6, 10, 12};
    for (GLuint a = 0; a < 5; ++a) {
        glEnableVertexAttribArray(a);
        glVertexAttribPointer(a, sizes[a], GL_FLOAT, GL_FALSE, stride,
                              reinterpret_cast<const void*>(static_cast<std::uintptr_t>(offsets[a] * sizeof(float))));
    }
    glBindVertexArray(0);
    impl_->indexCount = static_cast<GLsizei>(mesh.indices.size());
    impl_->meshHasUvs = uvs;
}

void Renderer::setTexture(TextureSlot slot, const image::Image8& img, shading::Filter filter, shading::Wrap wrap) {
    if (img.empty() || img.channels() < 1 || img.channels() > 4)
        throw InputError("texture", "", "needs a non-empty image with 1 to 4 channels");
    Texture& t = impl_->textures[static_cast<std::size_t>(slot)];
    if (slot == TextureSlot::Reflectance)
        uploadReflectance(t, img, filter, wrap);
    else
        upload(t, img, filter, wrap);
    t.user = true;
}

void Renderer::clearTexture(TextureSlot slot) {
    Texture& t = impl_->textures[static_cast<std::size_t>(slot)];
    t.user = false;
    switch (slot) {
        case TextureSlot::Diffuse:
            upload(t, solid(255, 255, 255), shading::Filter::Nearest, shading::Wrap::Repeat);
            break;
        case TextureSlot::Reflectance:
            upload(t, solid(128, 128, 255), shading::Filter::Nearest, shading::Wrap::Repeat);
            break;
        case TextureSlot::Highlight:
            impl_->highlightShininess = -1.0f;
            break;
    }
}

// Which program draws the frame: the mode's, its headlight variant when the
// light is exactly at the eye (the modes that light per pixel then read V for
// L: the same values, fewer varyings; common_shading.glsl), or a procedural
// specialisation compiled on first use.
Program& Renderer::Impl::programFor(const shading::FrameSetup& frame, const shading::ModeInfo& info) {
    const int mode = static_cast<int>(frame.mode);
    const bool lampAtEye = frame.light == frame.eye && info.headlight;
    // The procedural modes, specialised for speed (the debug view,
    // procedural-normals, uses the general program).
    if (frame.mode == shading::Mode::Procedural || frame.mode == shading::Mode::ClearcoatProcedural) {
        const noise::FractalParams& n = frame.procedural.noise;
        const std::array<int, 6> key = {mode,
                                        n.octaves,
                                        frame.procedural.space == shading::NoiseSpace::Object ? 1 : 0,
                                        n.tileable ? 1 : 0,
                                        n.turbulence ? 1 : 0,
                                        lampAtEye ? 1 : 0};
        auto it = procedural.find(key);
        if (it == procedural.end())
            it = procedural
                     .emplace(key, link(mode, fmt::format("#define MUCOSA_PROCEDURAL_OCTAVES {}\n"
                                                          "#define MUCOSA_PROCEDURAL_SPACE {}\n"
                                                          "#define MUCOSA_PROCEDURAL_TILEABLE {}\n"
                                                          "#define MUCOSA_PROCEDURAL_TURBULENCE {}\n{}",
                                                          key[1], key[2], key[3], key[4],
                                                          lampAtEye ? "#define MUCOSA_HEADLIGHT 1\n" : "")))
                     .first;
        return it->second;
    }
    return lampAtEye && !info.procedural ? this->headlight[static_cast<std::size_t>(mode)]
                                         : programs[static_cast<std::size_t>(mode)];
}

// Multitexture's highlight texture follows the shininess unless the user gave one.
void Renderer::Impl::refreshHighlight(const shading::ModeInfo& info, float shininess) {
    Texture& hl = textures[static_cast<std::size_t>(TextureSlot::Highlight)];
    if (!info.readsHighlight || hl.user || highlightShininess == shininess) return;
    upload(hl, shading::highlightSphereMap(shading::kHighlightTextureSize, shininess), shading::Filter::Linear,
           shading::Wrap::Clamp);
    highlightShininess = shininess;
}

void Renderer::Impl::uploadUniforms(Program& p, const shading::FrameSetup& frame, const shading::glsl::Frame& f,
                                    const shading::glsl::Material& m, const shading::ModeInfo& info) {
    glUseProgram(p.id);
    p.frame.upload(&f);
    p.material.upload(&m);
    p.procedural.set(frame);
    if (!info.procedural) return;
    const noise::FractalParams& n = frame.procedural.noise;
    const int z0 = permutationSliceZ0(n.z);
    if (permutationVersion == 0 || permutation.seed != n.seed || permutation.sliceZ0 != z0) {
        permutation = permutationUniforms(n.seed, n.z);
        ++permutationVersion;
    }
    // Uniform values live in the program: upload when this program last saw other tables.
    if (p.permutationVersion != permutationVersion) {
        p.procedural.setPermutation(permutation);
        p.permutationVersion = permutationVersion;
    }
}

void Renderer::Impl::bindTextures(bool specularAA) {
    for (GLuint unit = 0; unit < 3; ++unit) {
        glActiveTexture(GL_TEXTURE0 + unit);
        glBindTexture(GL_TEXTURE_2D, textures[unit].id);
    }
    // Anti-aliasing off: the map's full-resolution level only, as the paper
    // sampled it. Set on the texture (the shader samples the map once, with
    // texture(), either way: a select between two lookups would make a SIMD
    // rasteriser such as llvmpipe do both).
    Texture& rt = textures[static_cast<std::size_t>(TextureSlot::Reflectance)];
    const bool mipFilter = rt.minFilter != GL_LINEAR && rt.minFilter != GL_NEAREST;
    const GLint wantMin = !specularAA && mipFilter ? GL_LINEAR : rt.minFilter;
    if (wantMin != rt.boundMin) {
        glActiveTexture(GL_TEXTURE0 + static_cast<GLuint>(TextureSlot::Reflectance));
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, wantMin);
        rt.boundMin = wantMin;
    }
}

// The chunks inside the view frustum, contiguous ranges merged, in one call.
void Renderer::Impl::drawVisibleChunks(const glm::mat4& viewProj) {
    drawOffsets.clear();
    drawCounts.clear();
    std::size_t drawn = 0;
    for (const Chunk& c : chunks) {
        if (outsideFrustum(c, viewProj)) continue;
        if (!drawCounts.empty() && reinterpret_cast<std::uintptr_t>(drawOffsets.back()) / sizeof(std::uint32_t) +
                                           static_cast<std::uintptr_t>(drawCounts.back()) ==
                                       static_cast<std::uintptr_t>(c.first))
            drawCounts.back() += c.count;
        else {
            drawOffsets.push_back(
                reinterpret_cast<const void*>(static_cast<std::uintptr_t>(c.first) * sizeof(std::uint32_t)));
            drawCounts.push_back(c.count);
        }
        drawn += static_cast<std::size_t>(c.count / 3);
    }
    lastDrawnTriangles = drawn;
    glBindVertexArray(vao);
    if (!drawCounts.empty())
        glMultiDrawElements(GL_TRIANGLES, drawCounts.data(), GL_UNSIGNED_INT, drawOffsets.data(),
                            static_cast<GLsizei>(drawCounts.size()));
    glBindVertexArray(0);
}

namespace {

// Depth test, and back faces culled only for meshes declared closed
// (watertight and consistently wound), where a face turned away from the eye
// is hidden by a nearer one, so culling changes no pixel. `split`: the
// surface pass writes body light and specular apart (alpha: no specular where
// nothing is drawn).
void setPipelineState(const shading::FrameSetup& frame, bool split) {
    glClearColor(0, 0, 0, split ? 0.0f : 1.0f);
    glClearDepth(1.0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    if (frame.cullBackFaces) {
        glEnable(GL_CULL_FACE);
        glFrontFace(GL_CCW);
        glCullFace(frame.normalSign > 0 ? GL_BACK : GL_FRONT);
    } else {
        glDisable(GL_CULL_FACE);
    }
    glDisable(GL_BLEND);
}

}  // namespace

void Renderer::draw(const shading::FrameSetup& frame) {
    const shading::ModeInfo& info = shading::info(frame.mode);
    if (shading::modeNeedsUvs(frame) && !impl_->meshHasUvs)
        throw InputError(
            "mode", "",
            fmt::format("'{}' needs texture coordinates and tangents, which the mesh lacks (procedural "
                        "noise in object space needs neither; or add UVs with mucosa mesh --uv centerline)",
                        info.name));
    Program& program = impl_->programFor(frame, info);
    const shading::glsl::Material m = shading::glsl::packMaterial(frame.params);
    const shading::glsl::Frame f = shading::glsl::packFrame(frame);
    impl_->refreshHighlight(info, m.shininess);
    // The photographic modes draw linear radiance into the HDR target; the
    // camera then develops it into the caller's framebuffer.
    // (A camera that changes nothing is skipped: the frame goes straight to
    // the target, whose 8-bit format clamps it.)
    // Scattering needs the HDR target too (its body light and specular apart).
    const bool scatter = shading::scattersLight(frame);
    const bool develop = info.photographic && (!shading::cameraIsIdentity(frame.params) || scatter);
    glUseProgram(program.id);
    glUniform1i(program.split, scatter ? 1 : 0);
    if (impl_->lens.active()) {
        impl_->drawThroughLens(frame, program, f, m, info, develop, scatter);
        return;
    }
    GLint target = 0, viewport[4] = {0, 0, 0, 0};
    if (develop) {
        glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &target);
        glGetIntegerv(GL_VIEWPORT, viewport);
        impl_->hdr.ensure(viewport[2], viewport[3]);
        glBindFramebuffer(GL_FRAMEBUFFER, impl_->hdr.fbo);
        glViewport(0, 0, viewport[2], viewport[3]);
    }
    setPipelineState(frame, scatter);
    if (develop && frame.params[shading::Param::Mask] != 0.0f) impl_->occludeOutsideMask(frame);
    impl_->uploadUniforms(program, frame, f, m, info);
    impl_->bindTextures(frame.specularAA);
    impl_->drawVisibleChunks(f.viewProj);
    if (scatter) {
        const int size[2] = {viewport[2], viewport[3]};
        impl_->scatterImage(frame, shading::glsl::toMat4(frame.projection), impl_->hdr.color, impl_->hdr.depth, size,
                            {0, 0, size[0], size[1]}, GL_TEXTURE_2D, impl_->hdr.color);
    }
    if (develop) impl_->developFrame(frame, target, viewport);
}

// The pixels outside the scope's mask are black whatever the surface there:
// fill the depth buffer at the near plane over them, so the surface pass's
// fragments there fail the depth test before they are shaded (on llvmpipe
// a circle in a 640x480 frame leaves 41 % of the pixels unshaded).
void Renderer::Impl::occludeOutsideMask(const shading::FrameSetup& frame) {
    const shading::glsl::Camera cam = shading::glsl::packCamera(frame, 1.0f);
    glUseProgram(mask.id);
    mask.camera.upload(&cam);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    glDisable(GL_CULL_FACE);
    glBindVertexArray(postVao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    if (frame.cullBackFaces) glEnable(GL_CULL_FACE);
}

// The scattering (scatter.frag) over a perspective image of size[0] x size[1]
// drawn with `projection`, within `rect` (x0, y0, x1, y1): `source` (body
// light, specular) and `depth` in, the radiance out into `dest` (a 2D
// texture or a cube's face, destTarget), which may be `source`.
void Renderer::Impl::scatterImage(const shading::FrameSetup& frame, const glm::mat4& projection, GLuint source,
                                  GLuint depth, const int size[2], const std::array<int, 4>& rect, GLenum destTarget,
                                  GLuint dest) {
    const auto& d = frame.params.color(shading::Param::Scatter);
    scatter.setKernel({d[0], d[1], d[2]});
    scatter.ensure(size[0], size[1]);
    // The source as it is (the last pass reads it while it writes `dest`, which may be the source).
    glBindFramebuffer(GL_READ_FRAMEBUFFER, scatter.readFbo);
    glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, source, 0);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, scatter.keptFbo);
    glDisable(GL_SCISSOR_TEST);
    glBlitFramebuffer(rect[0], rect[1], rect[2], rect[3], rect[0], rect[1], rect[2], rect[3], GL_COLOR_BUFFER_BIT,
                      GL_NEAREST);
    glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, 0, 0);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glEnable(GL_SCISSOR_TEST);
    glUseProgram(scatter.program);
    glUniform4i(scatter.rect, rect[0], rect[1], rect[2], rect[3]);
    glUniform2f(scatter.projection, projection[2][2], projection[3][2]);
    glUniform2f(scatter.focal, projection[0][0] * 0.5f * static_cast<float>(size[0]),
                projection[1][1] * 0.5f * static_cast<float>(size[1]));
    glUniform1f(scatter.share, frame.params[shading::Param::ScatterShare]);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, depth);
    glBindVertexArray(postVao);
    const int half[4] = {rect[0] / 2, rect[1] / 2, (rect[2] + 1) / 2, (rect[3] + 1) / 2};  // scatterHalfRect
    glViewport(0, 0, (size[0] + 1) / 2, (size[1] + 1) / 2);
    glScissor(half[0], half[1], half[2] - half[0], half[3] - half[1]);
    // 0: along x, into the first half-size image.
    glBindFramebuffer(GL_FRAMEBUFFER, scatter.fboA);
    glUniform1i(scatter.pass, 0);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, scatter.kept);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    // 1: along y, into the second.
    glBindFramebuffer(GL_FRAMEBUFFER, scatter.fboB);
    glUniform1i(scatter.pass, 1);
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D, scatter.halfA);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    // 2: full size, into the destination.
    glBindFramebuffer(GL_FRAMEBUFFER, scatter.finalFbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, destTarget, dest, 0);
    glViewport(0, 0, size[0], size[1]);
    glScissor(rect[0], rect[1], rect[2] - rect[0], rect[3] - rect[1]);
    glUniform1i(scatter.pass, 2);
    glBindTexture(GL_TEXTURE_2D, scatter.halfB);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, 0, 0);
    glBindVertexArray(0);
    for (GLenum unit : {GL_TEXTURE2, GL_TEXTURE1, GL_TEXTURE0}) {
        glActiveTexture(unit);
        glBindTexture(GL_TEXTURE_2D, 0);
    }
    glDisable(GL_SCISSOR_TEST);
    glEnable(GL_DEPTH_TEST);
}

// The camera (camera.glsl): meter the HDR frame on a kMeterGrid^2 grid (a
// nearest-neighbour blit picks the same pixels as shading::meterPixel), set
// the exposure (shading::exposureFor) and the veiling glare
// (shading::veilingGlare), then the post pass into `target`.
void Renderer::Impl::developFrame(const shading::FrameSetup& frame, GLint target, const GLint viewport[4]) {
    const bool fixed = frame.fixedExposure > 0.0f;
    if ((frame.frameIndex == 0 || frame.restartExposure) && !fixed) exposure = {};
    float metered = 0.0f;
    glm::vec3 veil(0.0f);
    const bool meter = frame.params[shading::Param::AutoExposure] != 0.0f && !fixed;
    if (meter || frame.params[shading::Param::Flare] > 0.0f) {
        constexpr int n = shading::kMeterGrid;
        glBindFramebuffer(GL_READ_FRAMEBUFFER, hdr.fbo);
        glBindFramebuffer(GL_DRAW_FRAMEBUFFER, hdr.meterFbo);
        glBlitFramebuffer(0, 0, hdr.width, hdr.height, 0, 0, n, n, GL_COLOR_BUFFER_BIT, GL_NEAREST);
        std::vector<float> rgba(4 * static_cast<std::size_t>(n) * n), rgb(3 * static_cast<std::size_t>(n) * n);
        glBindFramebuffer(GL_READ_FRAMEBUFFER, hdr.meterFbo);
        glReadPixels(0, 0, n, n, GL_RGBA, GL_FLOAT, rgba.data());
        for (std::size_t i = 0; i < static_cast<std::size_t>(n) * n; ++i)
            for (std::size_t k = 0; k < 3; ++k) rgb[3 * i + k] = rgba[4 * i + k];
        if (meter) metered = shading::meterLuminance(rgb.data(), frame);
        const std::array<float, 3> v = shading::veilingGlare(rgb.data(), frame);
        veil = glm::vec3(v[0], v[1], v[2]);
    }
    const shading::glsl::Camera cam =
        shading::glsl::packCamera(frame, shading::exposureFor(frame, metered, exposure), veil);
    glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(target));
    glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glUseProgram(post.id);
    post.camera.upload(&cam);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, hdr.color);
    glBindVertexArray(postVao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    glEnable(GL_DEPTH_TEST);
}

int lensFaceSize(const image::ImageF& rays) {
    if (rays.channels() != 3) throw InputError("lens rays", "", "need 3 channels (x, y, z)");
    // The smallest angle between neighbouring pixels' rays: a face's centre
    // texel spans 2 / faceSize radians.
    double smallest = M_PI;
    auto ray = [&](int x, int y) { return glm::dvec3(rays.at(x, y, 0), rays.at(x, y, 1), rays.at(x, y, 2)); };
    for (int y = 0; y < rays.height(); ++y)
        for (int x = 0; x < rays.width(); ++x) {
            const glm::dvec3 a = ray(x, y);
            if (glm::dot(a, a) == 0) continue;
            for (const auto& [dx, dy] : {std::pair{1, 0}, std::pair{0, 1}}) {
                if (x + dx >= rays.width() || y + dy >= rays.height()) continue;
                const glm::dvec3 b = ray(x + dx, y + dy);
                if (glm::dot(b, b) == 0) continue;
                smallest = std::min(smallest, std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)));
            }
        }
    return std::clamp(static_cast<int>(std::ceil(2.0 / std::max(smallest, 1e-6))), 16, 4096);
}

namespace {

// The widest ray (OpenCV axes) from the axis as max(|x|, |y|) / z: the
// half-width of the one square perspective face that holds every ray, or
// infinity when a ray is 90 degrees or more from the axis.
double widestRayTan(const image::ImageF& rays) {
    double widest = 0;
    for (int y = 0; y < rays.height(); ++y)
        for (int x = 0; x < rays.width(); ++x) {
            const double dx = rays.at(x, y, 0), dy = rays.at(x, y, 1), dz = rays.at(x, y, 2);
            if (dx == 0 && dy == 0 && dz == 0) continue;
            if (!(dz > 0)) return std::numeric_limits<double>::infinity();
            widest = std::max(widest, std::max(std::abs(dx), std::abs(dy)) / dz);
        }
    return widest;
}

// The lens's framebuffer, bound, with its faceSize-square depth buffer; the
// caller attaches the colour.
void bindFaceTarget(LensTarget& t, int faceSize) {
    t.depth = makeDepthTexture(faceSize, faceSize);
    glGenFramebuffers(1, &t.fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, t.fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, t.depth, 0);
}

// The rays as the remap pass reads them: eye axes (OpenCV's y and z
// negated), rows bottom-up as GL counts them, w = 1 where there is a ray.
void uploadRays(LensTarget& t, const image::ImageF& rays) {
    const int w = rays.width(), h = rays.height();
    std::vector<float> texels(4 * static_cast<std::size_t>(w) * h, 0.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const glm::vec3 d(rays.at(x, y, 0), -rays.at(x, y, 1), -rays.at(x, y, 2));
            if (glm::dot(d, d) == 0.0f) continue;
            float* o = &texels[4 * (static_cast<std::size_t>(h - 1 - y) * w + x)];
            o[0] = d.x, o[1] = d.y, o[2] = d.z, o[3] = 1.0f;
        }
    glGenTextures(1, &t.rays);
    glBindTexture(GL_TEXTURE_2D, t.rays);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, texels.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
}

// One wide perspective face holding every ray (max(|x|, |y|) / z <= widest):
// square, symmetric about the axis, kOneFaceDensity texels per output pixel
// where the rays are densest (unless `faceSize` says), the texels the rays
// reach (plus their bilinear footprint) in rects[0].
void makeOneFace(LensTarget& t, const image::ImageF& rays, double widest, int faceSize) {
    const int w = rays.width(), h = rays.height();
    if (faceSize <= 0) {
        // lensFaceSize: a cube face (tan 1) with a texel per ray at the densest.
        const double perTan = 0.5 * lensFaceSize(rays) * kOneFaceDensity;
        faceSize = std::clamp(static_cast<int>(std::ceil(2.0 * std::max(widest, 1e-3) * perTan)) + 4, 16, 4096);
    }
    faceSize = std::max(faceSize, 16);
    if (faceSize > 8192) throw InputError("lens", "", fmt::format("a face of {} pixels is too large", faceSize));
    // Two texels to spare beyond the widest ray, for the bilinear footprint.
    const double tanHalf = std::max(widest, 1e-3) * static_cast<double>(faceSize) / (faceSize - 4);
    const std::uint64_t faceTexels = static_cast<std::uint64_t>(faceSize) * static_cast<std::uint64_t>(faceSize);
    requireMemory(saturatingMul(faceTexels, 8 + 4) + saturatingMul(static_cast<std::uint64_t>(w) * h, 16),
                  "the lens's face");
    std::array<int, 4>& r = t.rects[0];
    r = {faceSize, faceSize, 0, 0};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double dz = rays.at(x, y, 2);
            if (!(dz > 0)) continue;
            const double s = (0.5 * rays.at(x, y, 0) / (dz * tanHalf) + 0.5) * faceSize;
            const double u = (0.5 * -rays.at(x, y, 1) / (dz * tanHalf) + 0.5) * faceSize;  // GL's t grows up
            r[0] = std::min(r[0], static_cast<int>(std::floor(s)) - 2);
            r[1] = std::min(r[1], static_cast<int>(std::floor(u)) - 2);
            r[2] = std::max(r[2], static_cast<int>(std::ceil(s)) + 2);
            r[3] = std::max(r[3], static_cast<int>(std::ceil(u)) + 2);
        }
    r = {std::max(r[0], 0), std::max(r[1], 0), std::min(r[2], faceSize), std::min(r[3], faceSize)};
    t.faces = {};
    t.faces[0] = r[2] > r[0] && r[3] > r[1];
    t.faceSize = faceSize;
    t.planeTan = static_cast<float>(tanHalf);
    t.width = w;
    t.height = h;
    uploadRays(t, rays);
    glGenTextures(1, &t.plane);
    glBindTexture(GL_TEXTURE_2D, t.plane);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA16F, faceSize, faceSize, 0, GL_RGBA, GL_FLOAT, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    bindFaceTarget(t, faceSize);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, t.plane, 0);
    const bool complete = glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    if (!complete) {
        const GLuint remap = t.remap.id;
        t.release();
        t.remap.id = remap;
        throw GraphicsError("framebuffer", "", "the lens's face (RGBA16F) is incomplete");
    }
}

}  // namespace

bool drawnInOneFace(const image::ImageF& rays) {
    return widestRayTan(rays) <= kOneFaceMaxTan;
}

void clipRaysToMask(image::ImageF& rays, const shading::ParamSet& params) {
    if (rays.empty() || params[shading::Param::Mask] == 0.0f) return;
    shading::FrameSetup f;
    f.width = rays.width();
    f.height = rays.height();
    f.params = params;
    shading::glsl::Camera c = shading::glsl::packCamera(f, 1.0f);
    // The mask widened by the point-spread function's reach and a pixel.
    c.maskRadius += static_cast<float>(shading::glsl::kSoftRadius + 1) / (0.5f * std::min(c.width, c.height));
    for (int y = 0; y < rays.height(); ++y)
        for (int x = 0; x < rays.width(); ++x)
            if (shading::glsl::fovMask(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, c) <= 0.0f)
                for (int k = 0; k < 3; ++k) rays.at(x, y, k) = 0.0f;
}

void Renderer::setLensRays(const image::ImageF& rays, int faceSize) {
    LensTarget& t = impl_->lens;
    const GLuint remap = t.remap.id;
    t.release();
    t.remap.id = remap;
    if (rays.empty()) return;
    if (rays.channels() != 3) throw InputError("lens rays", "", "need 3 channels (x, y, z)");
    const double widest = widestRayTan(rays);
    if (widest <= kOneFaceMaxTan) {
        makeOneFace(t, rays, widest, faceSize);
        return;
    }
    if (faceSize <= 0) faceSize = lensFaceSize(rays);
    if (faceSize > 8192) throw InputError("lens", "", fmt::format("cube faces of {} pixels are too large", faceSize));
    const int w = rays.width(), h = rays.height();
    const std::uint64_t faceTexels = static_cast<std::uint64_t>(faceSize) * static_cast<std::uint64_t>(faceSize);
    requireMemory(saturatingMul(faceTexels, 6 * 8 + 4) + saturatingMul(static_cast<std::uint64_t>(w) * h, 16),
                  "the lens's cube map");
    // The faces the rays (or their bilinear footprint) reach, in eye axes
    // (OpenCV's y and z negated).
    const float edge = 1.0f - 2.0f / static_cast<float>(faceSize);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const glm::vec3 d(rays.at(x, y, 0), -rays.at(x, y, 1), -rays.at(x, y, 2));
            if (glm::dot(d, d) == 0.0f) continue;
            const glm::vec3 a = glm::abs(d);
            const float major = std::max({a.x, a.y, a.z});
            for (int k = 0; k < 3; ++k)
                if (a[k] >= edge * major) {
                    const int face = 2 * k + (d[k] < 0);
                    const auto [s, tc] = cubeFaceCoordinates(d, face);
                    // The bilinear footprint, plus a texel to spare.
                    const float fs = s * static_cast<float>(faceSize), ft = tc * static_cast<float>(faceSize);
                    std::array<int, 4>& r = t.rects[static_cast<std::size_t>(face)];
                    const std::array<int, 4> here = {
                        static_cast<int>(std::floor(fs)) - 2, static_cast<int>(std::floor(ft)) - 2,
                        static_cast<int>(std::ceil(fs)) + 2, static_cast<int>(std::ceil(ft)) + 2};
                    if (!t.faces[static_cast<std::size_t>(face)]) {
                        r = here;
                    } else {
                        r[0] = std::min(r[0], here[0]), r[1] = std::min(r[1], here[1]);
                        r[2] = std::max(r[2], here[2]), r[3] = std::max(r[3], here[3]);
                    }
                    t.faces[static_cast<std::size_t>(face)] = true;
                }
        }
    for (std::array<int, 4>& r : t.rects) {
        r[0] = std::max(r[0], 0), r[1] = std::max(r[1], 0);
        r[2] = std::min(r[2], faceSize), r[3] = std::min(r[3], faceSize);
    }
    t.faceSize = faceSize;
    t.width = w;
    t.height = h;
    uploadRays(t, rays);
    glGenTextures(1, &t.cube);
    glBindTexture(GL_TEXTURE_CUBE_MAP, t.cube);
    for (int i = 0; i < 6; ++i)
        glTexImage2D(static_cast<GLenum>(GL_TEXTURE_CUBE_MAP_POSITIVE_X + i), 0, GL_RGBA16F, faceSize, faceSize, 0,
                     GL_RGBA, GL_FLOAT, nullptr);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAX_LEVEL, 0);
    glEnable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
    bindFaceTarget(t, faceSize);
    for (int i = 0; i < 6; ++i) {
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0,
                               static_cast<GLenum>(GL_TEXTURE_CUBE_MAP_POSITIVE_X + i), t.cube, 0);
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
            t.release();
            t.remap.id = remap;
            throw GraphicsError("framebuffer", "", "a cube-map face (RGBA16F) is incomplete");
        }
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

int Renderer::cubeFaceSize() const noexcept {
    return impl_->lens.faceSize;
}

float Renderer::lastExposure() const noexcept {
    return std::exp2(impl_->exposure.ev);
}

// The one wide face (the frame's camera, a square frustum of half-width
// planeTan), or each cube face the rays reach (the frame's camera turned to
// the face, a 90 degree square frustum), with the frame's near and far
// planes; then the remap pass into the HDR target (develop) or the caller's
// framebuffer.
void Renderer::Impl::drawThroughLens(const shading::FrameSetup& frame, Program& program, const shading::glsl::Frame& f,
                                     const shading::glsl::Material& m, const shading::ModeInfo& info, bool develop,
                                     bool scatters) {
    GLint target = 0, viewport[4] = {0, 0, 0, 0};
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &target);
    glGetIntegerv(GL_VIEWPORT, viewport);
    if (viewport[2] != lens.width || viewport[3] != lens.height)
        throw InputError("lens", "",
                         fmt::format("its rays are for a {}x{} frame, the frame is {}x{}", lens.width, lens.height,
                                     viewport[2], viewport[3]));
    // The frame's near and far planes, from its projection (OpenGL's
    // perspective: P[2][2] = -(f + n) / (f - n), P[3][2] = -2 f n / (f - n)).
    const float a = frame.projection[10], b = frame.projection[14];
    const float nearPlane = b / (a - 1.0f), farPlane = b / (a + 1.0f);
    glm::mat4 proj(0.0f);
    proj[0][0] = proj[1][1] = 1.0f;
    proj[2][2] = -(farPlane + nearPlane) / (farPlane - nearPlane);
    proj[2][3] = -1.0f;
    proj[3][2] = -2.0f * farPlane * nearPlane / (farPlane - nearPlane);
    glBindFramebuffer(GL_FRAMEBUFFER, lens.fbo);
    glViewport(0, 0, lens.faceSize, lens.faceSize);
    if (lens.plane != 0 && lens.faces[0]) {
        // The one wide face: the camera's own view, a square frustum of half-width planeTan.
        glm::mat4 wide = proj;
        wide[0][0] = wide[1][1] = 1.0f / lens.planeTan;
        const std::array<int, 4>& r = lens.rects[0];
        glEnable(GL_SCISSOR_TEST);
        glScissor(r[0], r[1], r[2] - r[0], r[3] - r[1]);
        setPipelineState(frame, scatters);
        shading::glsl::Frame face = f;
        face.viewProj = wide * face.view;
        uploadUniforms(program, frame, face, m, info);
        bindTextures(frame.specularAA);
        drawVisibleChunks(face.viewProj);
        const int size[2] = {lens.faceSize, lens.faceSize};
        if (scatters) scatterImage(frame, wide, lens.plane, lens.depth, size, r, GL_TEXTURE_2D, lens.plane);
    }
    if (lens.plane == 0 && scatters && lens.flat == 0) lens.flat = makeHalfTexture(lens.faceSize, lens.faceSize);
    for (int i = 0; i < 6 && lens.plane == 0; ++i) {
        if (!lens.faces[static_cast<std::size_t>(i)]) continue;
        const GLenum cubeFace = static_cast<GLenum>(GL_TEXTURE_CUBE_MAP_POSITIVE_X + i);
        // Scattering: the face is drawn flat, then scattered into the cube.
        glBindFramebuffer(GL_FRAMEBUFFER, lens.fbo);
        glViewport(0, 0, lens.faceSize, lens.faceSize);
        if (scatters)
            glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, lens.flat, 0);
        else
            glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, cubeFace, lens.cube, 0);
        const std::array<int, 4>& r = lens.rects[static_cast<std::size_t>(i)];
        glEnable(GL_SCISSOR_TEST);  // the clear and the draw: only what the rays read
        glScissor(r[0], r[1], r[2] - r[0], r[3] - r[1]);
        setPipelineState(frame, scatters);
        shading::glsl::Frame face = f;  // the lamp's axis, eye and light stay the camera's
        face.view = faceRotation(i) * f.view;
        face.viewProj = proj * face.view;
        uploadUniforms(program, frame, face, m, info);
        bindTextures(frame.specularAA);
        drawVisibleChunks(face.viewProj);
        const int size[2] = {lens.faceSize, lens.faceSize};
        if (scatters) scatterImage(frame, proj, lens.flat, lens.depth, size, r, cubeFace, lens.cube);
    }
    glDisable(GL_SCISSOR_TEST);
    if (develop) {
        hdr.ensure(viewport[2], viewport[3]);
        glBindFramebuffer(GL_FRAMEBUFFER, hdr.fbo);
        glViewport(0, 0, viewport[2], viewport[3]);
    } else {
        glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(target));
        glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
    }
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glUseProgram(lens.remap.id);
    glUniform1f(glGetUniformLocation(lens.remap.id, "uPlaneTan"), lens.plane != 0 ? lens.planeTan : 0.0f);
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D, lens.plane);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, lens.rays);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_CUBE_MAP, lens.cube);
    glBindVertexArray(postVao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    glBindTexture(GL_TEXTURE_CUBE_MAP, 0);
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D, 0);
    glActiveTexture(GL_TEXTURE0);
    glEnable(GL_DEPTH_TEST);
    if (develop) developFrame(frame, target, viewport);
}

}  // namespace mucosa::render
