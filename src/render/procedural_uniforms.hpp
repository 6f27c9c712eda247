#pragma once
// The GLSL side of shaders/procedural_noise.glsl: the permutation prelude
// (permAt over a uniform array: no texture) and the Procedural struct's
// uniforms, shared by the renderer and the GPU noise evaluator.
#include <array>
#include <cstdint>
#include <string_view>

#include <mucosa/shading/reference.hpp>

#include "render/gl.hpp"
#include "render/uniforms.hpp"

namespace mucosa::render {

// Declares uPerm (the 256-entry permutation as pairs perm[i] | perm[i + 1] << 8,
// an int array), uPermSlice (the hashes of one z slice, below), permAt,
// permPairAt and permSlicePairAt.
std::string_view permutationPrelude() noexcept;

// The uniform tables of a permutation: `pairs` for uPerm, and `slice` for
// uPermSlice: perm[perm[j] + Z0] | perm[perm[j] + Z0 + 1] << 8 with
// Z0 = floor(z) mod 256, the last two hash levels of the z slice that a
// texture-space fractal sum samples (procedural_noise.glsl).
struct PermutationTables {
    std::uint64_t seed = 0;
    int sliceZ0 = 0;
    std::array<GLint, 256> pairs{};
    std::array<GLint, 256> slice{};
};
PermutationTables permutationUniforms(std::uint64_t seed, double z);
// Z0 of the slice at z, as the shader finds it: floor(float(z)) mod 256.
int permutationSliceZ0(double z) noexcept;

// Uniform locations of uProcedural.* and uPerm in one program.
class ProceduralUniforms {
public:
    ProceduralUniforms() = default;
    explicit ProceduralUniforms(GLuint program);
    // Every field of uProcedural from the frame (the program must be in use).
    void set(const shading::FrameSetup& frame) const;
    void setPermutation(const PermutationTables& tables) const;

private:
    UniformBlock fields_;
    GLint perm_ = -1, slice_ = -1;
};

}  // namespace mucosa::render
