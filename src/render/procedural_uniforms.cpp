#include "render/procedural_uniforms.hpp"

#include <cmath>

#include <mucosa/noise/perlin.hpp>

#include "shading/glsl.hpp"

namespace mucosa::render {

// A scalar array, not ivec4[64] with a component select: llvmpipe gathers a
// scalar array element in one load, which halves the cost of an octave
// (bench_render: 15.2 -> 7.3 ms per octave at 640x480, before the
// per-variant programs of renderer.cpp took it to 4.5 ms). Two tables of 256
// uniform components, 2048 even if a driver pads each element to a vec4:
// within every desktop GPU's GL_MAX_FRAGMENT_UNIFORM_COMPONENTS (>= 4096).
// Each element holds a pair, perm[i] | perm[i + 1] << 8: the noise reads an
// index and its successor in one lookup where the lattice allows
// (plain noise: 7 lookups per octave instead of 14).
// uPermSlice composes the last two hash levels for the frame's z slice (the
// same z for every octave of a texture-space sum), so such an octave needs 5
// lookups, one level deep after the first: the renderer keeps it in step with
// uProcedural.z (and the tests check the pictures against the reference).
std::string_view permutationPrelude() noexcept {
    return "uniform int uPerm[256];\n"
           "uniform int uPermSlice[256];\n"
           "int permPairAt(int i) { return uPerm[i & 255]; }\n"
           "int permAt(int i) { return uPerm[i & 255] & 255; }\n"
           "int permSlicePairAt(int j, int Z0) { return uPermSlice[j & 255]; }\n";
}

int permutationSliceZ0(double z) noexcept {
    return static_cast<int>(std::floor(static_cast<float>(z))) & 255;
}

PermutationTables permutationUniforms(std::uint64_t seed, double z) {
    const noise::Permutation perm = noise::Permutation::fromSeed(seed);
    PermutationTables t;
    t.seed = seed;
    t.sliceZ0 = permutationSliceZ0(z);
    for (int i = 0; i < 256; ++i) {
        const auto k = static_cast<std::size_t>(i);
        t.pairs[k] = perm[i] | perm[(i + 1) & 255] << 8;
        const int a = perm[i] + t.sliceZ0;
        t.slice[k] = perm[a & 255] | perm[(a + 1) & 255] << 8;
    }
    return t;
}

ProceduralUniforms::ProceduralUniforms(GLuint program) : fields_(program, proceduralUniforms()) {
    perm_ = glGetUniformLocation(program, "uPerm");
    slice_ = glGetUniformLocation(program, "uPermSlice");
}

void ProceduralUniforms::set(const shading::FrameSetup& frame) const {
    const shading::glsl::Procedural p = shading::glsl::packProcedural(frame);
    fields_.upload(&p);
}

void ProceduralUniforms::setPermutation(const PermutationTables& tables) const {
    glUniform1iv(perm_, 256, tables.pairs.data());
    glUniform1iv(slice_, 256, tables.slice.data());
}

}  // namespace mucosa::render
