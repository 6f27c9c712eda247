#pragma once
// Compiling one GLSL stage, shared by the renderer and the GPU noise evaluator.
#include <string>

#include "render/gl.hpp"

namespace mucosa::render {

// Throws GraphicsError("shader <name>", ...) with the compiler's log.
GLuint compileShader(GLenum stage, const std::string& source, const std::string& name);

}  // namespace mucosa::render
