#pragma once
// The GLSL sources of shaders/, embedded at build time
// (src/render/embed_shaders.cmake).
#include <string>
#include <string_view>
#include <vector>

namespace mucosa::render {

struct EmbeddedShader {
    std::string_view name;  // file name, e.g. "surface_tissue.frag"
    std::string_view source;
};

const std::vector<EmbeddedShader>& embeddedShaders();

// Throws InternalError if `name` was not embedded.
std::string_view shaderSource(std::string_view name);

}  // namespace mucosa::render
