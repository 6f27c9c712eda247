#include <mucosa/render/gpu_noise.hpp>

#include <algorithm>
#include <string>

#include <mucosa/noise/perlin.hpp>
#include <mucosa/render/context.hpp>

#include "render/embedded_shaders.hpp"
#include "render/gl.hpp"
#include "render/procedural_uniforms.hpp"
#include "render/uniforms.hpp"
#include "render/shader.hpp"

namespace mucosa::render {

namespace {

constexpr const char* kVertex = R"(#version 330 core
void main() {
    // One triangle covering the viewport.
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
)";

constexpr const char* kFragment = R"(
uniform sampler2D uPoints;
uniform int uFunction;
uniform vec3 uPeriod;
uniform Procedural uProcedural;
out vec4 result;
void main() {
    vec3 p = texelFetch(uPoints, ivec2(gl_FragCoord.xy), 0).xyz;
    // Period 256 on every axis: plain noise, through the renderer's cheaper
    // overload (the same values, tested against mucosa::noise here too).
    if (uFunction == 0 && uPeriod == vec3(256.0f)) result = perlinNoiseGradient(p);
    else if (uFunction == 0) result = perlinNoiseGradient(p, uPeriod);
    else result = fractalNoise(p, 0.0f, uProcedural).h;
}
)";

}  // namespace

std::vector<std::array<float, 4>> evaluateNoiseOnGpu(const GpuNoiseRequest& request,
                                                     std::span<const std::array<float, 3>> points) {
    if (request.function != GpuNoiseFunction::Noise) noise::validate(request.params);
    std::vector<std::array<float, 4>> out(points.size());
    if (points.empty()) return out;
    const int width = static_cast<int>(std::min<std::size_t>(points.size(), 1024));
    const int height = static_cast<int>((points.size() + static_cast<std::size_t>(width) - 1) / width);
    std::vector<float> texels(static_cast<std::size_t>(width) * height * 3, 0.0f);
    for (std::size_t i = 0; i < points.size(); ++i)
        std::copy(points[i].begin(), points[i].end(), texels.begin() + static_cast<std::ptrdiff_t>(3 * i));

    const std::string common = std::string("#version 330 core\n") + std::string(permutationPrelude()) +
                               std::string(shaderSource("procedural_noise.glsl"));
    const GLuint program = linkProgram(kVertex, common + kFragment, "gpu_noise");

    GLuint tex[2], fbo = 0, vao = 0;
    glGenTextures(2, tex);
    glBindTexture(GL_TEXTURE_2D, tex[0]);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, width, height, 0, GL_RGB, GL_FLOAT, texels.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glBindTexture(GL_TEXTURE_2D, tex[1]);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, width, height, 0, GL_RGBA, GL_FLOAT, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glGenFramebuffers(1, &fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex[1], 0);
    const bool complete = glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
    if (complete) {
        glViewport(0, 0, width, height);
        glDisable(GL_DEPTH_TEST);
        glDisable(GL_CULL_FACE);
        glDisable(GL_BLEND);
        glUseProgram(program);
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, tex[0]);
        glUniform1i(glGetUniformLocation(program, "uPoints"), 0);
        glUniform1i(glGetUniformLocation(program, "uFunction"), request.function == GpuNoiseFunction::Noise ? 0 : 1);
        glUniform3f(glGetUniformLocation(program, "uPeriod"), static_cast<float>(request.period[0]),
                    static_cast<float>(request.period[1]), static_cast<float>(request.period[2]));
        shading::FrameSetup frame;
        frame.procedural.noise = request.params;
        frame.procedural.strength = 1.0f;
        frame.procedural.space =
            request.function == GpuNoiseFunction::FractalSolid ? shading::NoiseSpace::Object : shading::NoiseSpace::Uv;
        frame.specularAA = false;
        checkActiveUniforms(program, "gpu noise");
        const ProceduralUniforms uniforms(program);
        uniforms.set(frame);
        uniforms.setPermutation(permutationUniforms(request.params.seed, request.params.z));
        glGenVertexArrays(1, &vao);
        glBindVertexArray(vao);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glBindVertexArray(0);
        std::vector<float> result(static_cast<std::size_t>(width) * height * 4);
        glPixelStorei(GL_PACK_ALIGNMENT, 4);
        glReadPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, result.data());
        for (std::size_t i = 0; i < points.size(); ++i)
            std::copy(result.begin() + static_cast<std::ptrdiff_t>(4 * i),
                      result.begin() + static_cast<std::ptrdiff_t>(4 * i + 4), out[i].begin());
        glDeleteVertexArrays(1, &vao);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glDeleteFramebuffers(1, &fbo);
    glDeleteTextures(2, tex);
    glDeleteProgram(program);
    if (!complete) throw GraphicsError("float render target", "", "RGBA32F framebuffer is incomplete");
    return out;
}

}  // namespace mucosa::render
