#include "render/uniforms.hpp"

#include <array>
#include <cctype>
#include <type_traits>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>

#include "shading/glsl.hpp"

namespace mucosa::render {

namespace {

namespace glsl = shading::glsl;

template <class T>
constexpr UniformType uniformType() {
    if constexpr (std::is_same_v<T, float>)
        return UniformType::Float;
    else if constexpr (std::is_same_v<T, int>)
        return UniformType::Int;
    else if constexpr (std::is_same_v<T, glm::vec3>)
        return UniformType::Vec3;
    else if constexpr (std::is_same_v<T, glm::vec4>)
        return UniformType::Vec4;
    else {
        static_assert(std::is_same_v<T, glm::mat4>, "a uniform of a type the renderer cannot upload");
        return UniformType::Mat4;
    }
}

// u<Struct>.<field>: name, offset and type from the one C++ member.
#define MUCOSA_UNIFORM(Struct, field)                                                                       \
    UniformField {                                                                                          \
        "u" #Struct "." #field, offsetof(glsl::Struct, field), uniformType<decltype(glsl::Struct::field)>() \
    }

static_assert(std::is_standard_layout_v<glsl::Frame> && std::is_standard_layout_v<glsl::Material> &&
              std::is_standard_layout_v<glsl::Procedural> && std::is_standard_layout_v<glsl::Camera>);

constexpr std::array kFrame = {
    MUCOSA_UNIFORM(Frame, viewProj),   MUCOSA_UNIFORM(Frame, view),
    MUCOSA_UNIFORM(Frame, eye),        MUCOSA_UNIFORM(Frame, light),
    MUCOSA_UNIFORM(Frame, lampAxis),   MUCOSA_UNIFORM(Frame, normalSign),
    MUCOSA_UNIFORM(Frame, specularAA), MUCOSA_UNIFORM(Frame, diffuseUvTransform),
};
constexpr std::array kMaterial = {
    MUCOSA_UNIFORM(Material, baseColor),
    MUCOSA_UNIFORM(Material, mucusColor),
    MUCOSA_UNIFORM(Material, mucusOpacity),
    MUCOSA_UNIFORM(Material, specularStrength),
    MUCOSA_UNIFORM(Material, shininess),
    MUCOSA_UNIFORM(Material, bumpScale),
    MUCOSA_UNIFORM(Material, mapTiling),
    MUCOSA_UNIFORM(Material, ambient),
    MUCOSA_UNIFORM(Material, c),
    MUCOSA_UNIFORM(Material, d),
    MUCOSA_UNIFORM(Material, depthMin),
    MUCOSA_UNIFORM(Material, depthMax),
    MUCOSA_UNIFORM(Material, lightIntensity),
    MUCOSA_UNIFORM(Material, lampSourceRadius),
    MUCOSA_UNIFORM(Material, lampSpread),
    MUCOSA_UNIFORM(Material, wrap),
    MUCOSA_UNIFORM(Material, sheenStrength),
    MUCOSA_UNIFORM(Material, sheenShininess),
    MUCOSA_UNIFORM(Material, mucusF0),
    MUCOSA_UNIFORM(Material, clearcoat),
    MUCOSA_UNIFORM(Material, clearcoatRoughness),
    MUCOSA_UNIFORM(Material, baseRoughness),
};
constexpr std::array kCamera = {
    MUCOSA_UNIFORM(Camera, exposure),    MUCOSA_UNIFORM(Camera, vignettingPower), MUCOSA_UNIFORM(Camera, tanHalfFovX),
    MUCOSA_UNIFORM(Camera, tanHalfFovY), MUCOSA_UNIFORM(Camera, width),           MUCOSA_UNIFORM(Camera, height),
    MUCOSA_UNIFORM(Camera, mask),        MUCOSA_UNIFORM(Camera, maskRadius),      MUCOSA_UNIFORM(Camera, softness),
    MUCOSA_UNIFORM(Camera, fullWell),    MUCOSA_UNIFORM(Camera, readNoise),       MUCOSA_UNIFORM(Camera, toneCurve),
    MUCOSA_UNIFORM(Camera, frameSeed),   MUCOSA_UNIFORM(Camera, saturation),      MUCOSA_UNIFORM(Camera, knee),
    MUCOSA_UNIFORM(Camera, veil),
};
constexpr std::array kProcedural = {
    MUCOSA_UNIFORM(Procedural, frequency),  MUCOSA_UNIFORM(Procedural, octaves),
    MUCOSA_UNIFORM(Procedural, lacunarity), MUCOSA_UNIFORM(Procedural, gain),
    MUCOSA_UNIFORM(Procedural, z),          MUCOSA_UNIFORM(Procedural, turbulence),
    MUCOSA_UNIFORM(Procedural, tileable),   MUCOSA_UNIFORM(Procedural, strength),
    MUCOSA_UNIFORM(Procedural, space),      MUCOSA_UNIFORM(Procedural, scaleMm),
    MUCOSA_UNIFORM(Procedural, antialias),  MUCOSA_UNIFORM(Procedural, texels),
};
#undef MUCOSA_UNIFORM

// Every member is in its table: the sizes add up to the struct's (no padding
// in these structs of 4-byte scalars and glm vectors).
constexpr std::size_t bytes(UniformType t) {
    switch (t) {
        case UniformType::Float:
        case UniformType::Int:
            return 4;
        case UniformType::Vec3:
            return 12;
        case UniformType::Vec4:
            return 16;
        case UniformType::Mat4:
            return 64;
    }
    return 0;
}
template <std::size_t N>
constexpr std::size_t total(const std::array<UniformField, N>& fields) {
    std::size_t s = 0;
    for (const UniformField& f : fields) s += bytes(f.type);
    return s;
}
static_assert(total(kFrame) == sizeof(glsl::Frame), "a member of Frame is missing from kFrame");
static_assert(total(kMaterial) == sizeof(glsl::Material), "a member of Material is missing from kMaterial");
static_assert(total(kProcedural) == sizeof(glsl::Procedural), "a member of Procedural is missing from kProcedural");
static_assert(total(kCamera) == sizeof(glsl::Camera), "a member of Camera is missing from kCamera");

// The varyings, each named once (the struct gives the type).
struct Varying {
    std::string_view name;  // the struct member; the interface variable is v<Name>
    std::string_view type;  // GLSL
    std::size_t offset, bytes;
};
template <class T>
constexpr std::string_view glslType() {
    if constexpr (std::is_same_v<T, float>)
        return "float";
    else if constexpr (std::is_same_v<T, glm::vec2>)
        return "vec2";
    else if constexpr (std::is_same_v<T, glm::vec3>)
        return "vec3";
    else {
        static_assert(std::is_same_v<T, glm::vec4>, "a varying of a type the renderer cannot declare");
        return "vec4";
    }
}
#define MUCOSA_VARYING(field)                                                                   \
    Varying {                                                                                   \
#field, glslType < decltype(glsl::Varyings::field)>(), offsetof(glsl::Varyings, field), \
            sizeof(glsl::Varyings::field)                                                       \
    }
constexpr std::array kVaryings = {
    MUCOSA_VARYING(Lt),
    MUCOSA_VARYING(Vt),
    MUCOSA_VARYING(uv),
    MUCOSA_VARYING(T),
    MUCOSA_VARYING(B),
    MUCOSA_VARYING(N),
    MUCOSA_VARYING(diffuseLight),
    MUCOSA_VARYING(specular),
    MUCOSA_VARYING(sheen),
    MUCOSA_VARYING(sphereUv),
    MUCOSA_VARYING(P),
    MUCOSA_VARYING(tint),
};
#undef MUCOSA_VARYING
constexpr bool coversVaryings() {
    std::size_t next = 0;
    for (const Varying& v : kVaryings) {
        if (v.offset != next) return false;  // in declaration order, nothing between
        next += v.bytes;
    }
    return next == sizeof(glsl::Varyings);
}
static_assert(std::is_standard_layout_v<glsl::Varyings>);
static_assert(coversVaryings(), "kVaryings must list every member of Varyings, in order");

GLenum glType(UniformType t) {
    switch (t) {
        case UniformType::Float:
            return GL_FLOAT;
        case UniformType::Int:
            return GL_INT;
        case UniformType::Vec3:
            return GL_FLOAT_VEC3;
        case UniformType::Vec4:
            return GL_FLOAT_VEC4;
        case UniformType::Mat4:
            return GL_FLOAT_MAT4;
    }
    return GL_NONE;
}

}  // namespace

std::span<const UniformField> frameUniforms() noexcept {
    return kFrame;
}
std::span<const UniformField> materialUniforms() noexcept {
    return kMaterial;
}
std::span<const UniformField> proceduralUniforms() noexcept {
    return kProcedural;
}
std::span<const UniformField> cameraUniforms() noexcept {
    return kCamera;
}

UniformBlock::UniformBlock(GLuint program, std::span<const UniformField> fields) : fields_(fields) {
    loc_.reserve(fields.size());
    for (const UniformField& f : fields) loc_.push_back(glGetUniformLocation(program, std::string(f.name).c_str()));
}

void UniformBlock::upload(const void* data) const {
    const auto* base = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < fields_.size(); ++i) {
        const GLint loc = loc_[i];
        if (loc < 0) continue;
        const void* p = base + fields_[i].offset;
        switch (fields_[i].type) {
            case UniformType::Float:
                glUniform1fv(loc, 1, static_cast<const GLfloat*>(p));
                break;
            case UniformType::Int:
                glUniform1iv(loc, 1, static_cast<const GLint*>(p));
                break;
            case UniformType::Vec3:
                glUniform3fv(loc, 1, static_cast<const GLfloat*>(p));
                break;
            case UniformType::Vec4:
                glUniform4fv(loc, 1, static_cast<const GLfloat*>(p));
                break;
            case UniformType::Mat4:
                glUniformMatrix4fv(loc, 1, GL_FALSE, static_cast<const GLfloat*>(p));
                break;
        }
    }
}

std::string varyingDeclarations(bool vertexStage) {
    std::string decl, copy;
    for (const Varying& v : kVaryings) {
        const std::string var = fmt::format("v{}{}", static_cast<char>(std::toupper(v.name[0])), v.name.substr(1));
        decl += fmt::format("{} {} {};\n", vertexStage ? "out" : "in", v.type, var);
        copy +=
            vertexStage ? fmt::format("    {} = v.{};\n", var, v.name) : fmt::format("    v.{} = {};\n", v.name, var);
    }
    return vertexStage ? decl + "void writeVaryings(Varyings v) {\n" + copy + "}\n"
                       : decl + "Varyings readVaryings() {\n    Varyings v;\n" + copy + "    return v;\n}\n";
}

void checkActiveUniforms(GLuint program, const std::string& name) {
    GLint count = 0, longest = 0;
    glGetProgramiv(program, GL_ACTIVE_UNIFORMS, &count);
    glGetProgramiv(program, GL_ACTIVE_UNIFORM_MAX_LENGTH, &longest);
    std::string buffer(static_cast<std::size_t>(std::max(longest, 1)), '\0');
    for (GLint i = 0; i < count; ++i) {
        GLsizei length = 0;
        GLint size = 0;
        GLenum type = GL_NONE;
        glGetActiveUniform(program, static_cast<GLuint>(i), longest, &length, &size, &type, buffer.data());
        const std::string_view uniform(buffer.data(), static_cast<std::size_t>(length));
        std::span<const UniformField> table;
        if (uniform.starts_with("uFrame."))
            table = kFrame;
        else if (uniform.starts_with("uMaterial."))
            table = kMaterial;
        else if (uniform.starts_with("uProcedural."))
            table = kProcedural;
        else if (uniform.starts_with("uCamera."))
            table = kCamera;
        else
            continue;  // samplers and the permutation arrays are set by name where they are used
        const UniformField* field = nullptr;
        for (const UniformField& f : table)
            if (f.name == uniform) field = &f;
        if (field == nullptr)
            throw InternalError(
                fmt::format("shader {}: active uniform '{}' is not in the uniform tables "
                            "(src/render/uniforms.cpp)",
                            name, uniform));
        if (glType(field->type) != type || size != 1)
            throw InternalError(fmt::format("shader {}: uniform '{}' has GL type 0x{:x} x {}, the table says 0x{:x}",
                                            name, uniform, type, size, glType(field->type)));
    }
}

}  // namespace mucosa::render
