#pragma once
// The GLSL side of shaders/procedural_noise.glsl: the permutation prelude
// (permAt over a uniform array: no texture) and the Procedural struct's
// uniforms, shared by the renderer and the GPU noise evaluator.
#include <array>
#include <cstdint>
#include <string_view>

#include <mucosa/shading/reference.hpp>

#include "render/gl.hpp"

namespace mucosa::render {

// Declares uPerm (the 256-entry permutation as pairs perm[i] | perm[i + 1] << 8,
// an int array), permAt and permPairAt.
std::string_view permutationPrelude() noexcept;

// The permutation of `seed` as uPerm's 256 values (pairs).
std::array<GLint, 256> permutationUniform(std::uint64_t seed);

// Uniform locations of uProcedural.* and uPerm in one program.
class ProceduralUniforms {
public:
    ProceduralUniforms() = default;
    explicit ProceduralUniforms(GLuint program);
    // Every field of uProcedural from the frame (the program must be in use).
    void set(const shading::FrameSetup& frame) const;
    void setPermutation(const std::array<GLint, 256>& table) const;

private:
    std::array<GLint, 12> loc_{};
    GLint perm_ = -1;
};

}  // namespace mucosa::render
