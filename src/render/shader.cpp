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

GLuint linkProgram(const std::string& vertexSource, const std::string& fragmentSource, const std::string& name) {
    const GLuint vs = compileShader(GL_VERTEX_SHADER, vertexSource, name);
    GLuint fs = 0;
    try {
        fs = compileShader(GL_FRAGMENT_SHADER, fragmentSource, name);
    } catch (...) {
        glDeleteShader(vs);
        throw;
    }
    const GLuint program = glCreateProgram();
    glAttachShader(program, vs);
    glAttachShader(program, fs);
    glLinkProgram(program);
    glDeleteShader(vs);
    glDeleteShader(fs);
    GLint ok = 0;
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (!ok) {
        GLint len = 0;
        glGetProgramiv(program, GL_INFO_LOG_LENGTH, &len);
        std::string log(static_cast<std::size_t>(std::max(len, 1)), '\0');
        glGetProgramInfoLog(program, len, nullptr, log.data());
        glDeleteProgram(program);
        throw GraphicsError("shader " + name, "", "does not link: " + log);
    }
    return program;
}

}  // namespace mucosa::render
