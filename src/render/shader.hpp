#pragma once
// Compiling and linking GLSL, shared by the renderer and the GPU noise evaluator.
#include <string>

#include "render/gl.hpp"

namespace mucosa::render {

// Throws GraphicsError("shader <name>", ...) with the compiler's log.
GLuint compileShader(GLenum stage, const std::string& source, const std::string& name);
// Compiles both stages and links them; throws GraphicsError("shader <name>", ...)
// with the compiler's or linker's log. The stages are deleted either way.
GLuint linkProgram(const std::string& vertexSource, const std::string& fragmentSource, const std::string& name);

}  // namespace mucosa::render
