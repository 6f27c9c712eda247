#include "render/embedded_shaders.hpp"

#include <mucosa/core/error.hpp>

namespace mucosa::render {

std::string_view shaderSource(std::string_view name) {
    for (const EmbeddedShader& s : embeddedShaders())
        if (s.name == name) return s.source;
    MUCOSA_CHECK(false, "shader not embedded: " + std::string(name));
    return {};
}

}  // namespace mucosa::render
