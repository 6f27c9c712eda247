#include "render/shader.hpp"

#include <algorithm>

#include <mucosa/render/context.hpp>

namespace mucosa::render {

GLuint compileShader(GLenum stage, const std::string& source, const std::string& name) {
    GLuint s = glCreateShader(stage);
    const char* text = source.c_str();
    glShaderSource(s, 1, &text, nullptr);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        GLint len = 0;
        glGetShaderiv(s, GL_INFO_LOG_LENGTH, &len);
        std::string log(static_cast<std::size_t>(std::max(len, 1)), '\0');
        glGetShaderInfoLog(s, len, nullptr, log.data());
        glDeleteShader(s);
        throw GraphicsError("shader " + name, "", "does not compile: " + log);
    }
    return s;
}

}  // namespace mucosa::render
