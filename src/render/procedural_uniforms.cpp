#include "render/procedural_uniforms.hpp"

#include <mucosa/noise/perlin.hpp>

#include "shading/glsl.hpp"

namespace mucosa::render {

namespace {

constexpr std::array<const char*, 12> kNames = {
    "uProcedural.frequency", "uProcedural.octaves",    "uProcedural.lacunarity", "uProcedural.gain",
    "uProcedural.z",         "uProcedural.turbulence", "uProcedural.tileable",   "uProcedural.strength",
    "uProcedural.space",     "uProcedural.scaleMm",    "uProcedural.antialias",  "uProcedural.texels"};

}  // namespace

// A scalar array, not ivec4[64] with a component select: llvmpipe gathers a
// scalar array element in one load, which halves the cost of an octave
// (bench_render: 15.2 -> 7.3 ms per octave at 640x480, before the
// per-variant programs of renderer.cpp took it to 4.5 ms). 256 uniform
// components even if a driver pads each element to a vec4 (1024): within
// every desktop GPU's GL_MAX_FRAGMENT_UNIFORM_COMPONENTS (>= 4096).
// Each element holds a pair, perm[i] | perm[i + 1] << 8: the noise reads an
// index and its successor in one lookup where the lattice allows
// (perlinNoiseGradientPaired: 7 or 9 lookups per octave instead of 14).
std::string_view permutationPrelude() noexcept {
    return "uniform int uPerm[256];\n"
           "int permPairAt(int i) { return uPerm[i & 255]; }\n"
           "int permAt(int i) { return uPerm[i & 255] & 255; }\n";
}

std::array<GLint, 256> permutationUniform(std::uint64_t seed) {
    const noise::Permutation perm = noise::Permutation::fromSeed(seed);
    std::array<GLint, 256> t{};
    for (int i = 0; i < 256; ++i) t[static_cast<std::size_t>(i)] = perm[i] | perm[(i + 1) & 255] << 8;
    return t;
}

ProceduralUniforms::ProceduralUniforms(GLuint program) {
    for (std::size_t i = 0; i < kNames.size(); ++i) loc_[i] = glGetUniformLocation(program, kNames[i]);
    perm_ = glGetUniformLocation(program, "uPerm");
}

void ProceduralUniforms::set(const shading::FrameSetup& frame) const {
    const shading::glsl::Procedural p = shading::glsl::packProcedural(frame);
    glUniform1f(loc_[0], p.frequency);
    glUniform1i(loc_[1], p.octaves);
    glUniform1f(loc_[2], p.lacunarity);
    glUniform1f(loc_[3], p.gain);
    glUniform1f(loc_[4], p.z);
    glUniform1i(loc_[5], p.turbulence);
    glUniform1i(loc_[6], p.tileable);
    glUniform1f(loc_[7], p.strength);
    glUniform1i(loc_[8], p.space);
    glUniform1f(loc_[9], p.scaleMm);
    glUniform1i(loc_[10], p.antialias);
    glUniform1f(loc_[11], p.texels);
}

void ProceduralUniforms::setPermutation(const std::array<GLint, 256>& table) const {
    glUniform1iv(perm_, 256, table.data());
}

}  // namespace mucosa::render
