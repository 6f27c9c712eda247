#pragma once
// The shaders' struct uniforms (uFrame, uMaterial, uProcedural, uCamera), each field
// declared once: its GLSL name, its offset in the C++ twin of the GLSL struct
// (shading::glsl::Frame, Material, Procedural: the same source text, so the
// fields cannot drift apart) and its type, read from the C++ member's type.
// One loop uploads a struct (Filament's offsetof pattern); after every link,
// checkActiveUniforms compares the program's active uniforms with the tables,
// so a field the tables lack fails by name instead of silently keeping 0.
#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "render/gl.hpp"

namespace mucosa::render {

enum class UniformType { Float, Int, Vec3, Vec4, Mat4 };

struct UniformField {
    std::string_view name;  // "uMaterial.baseColor"
    std::size_t offset;     // in the C++ struct
    UniformType type;
};

std::span<const UniformField> frameUniforms() noexcept;       // uFrame: shading::glsl::Frame
std::span<const UniformField> materialUniforms() noexcept;    // uMaterial: shading::glsl::Material
std::span<const UniformField> proceduralUniforms() noexcept;  // uProcedural: shading::glsl::Procedural
std::span<const UniformField> cameraUniforms() noexcept;      // uCamera: shading::glsl::Camera (the post pass)

// The locations of one table's fields in one program (-1 where the program
// does not use a field).
class UniformBlock {
public:
    UniformBlock() = default;
    UniformBlock(GLuint program, std::span<const UniformField> fields);
    // Uploads every field from `data`, an object of the table's C++ struct;
    // the program must be in use.
    void upload(const void* data) const;

private:
    std::span<const UniformField> fields_;
    std::vector<GLint> loc_;
};

// The vertex stage's outputs: one per member of shading::glsl::Varyings
// (common_shading.glsl, where each is declared and described once), in the
// same order; a static_assert checks that the list covers the struct. The
// renderer prepends the generated declarations to surface_tissue.vert
// ("out vec3 vLt; ..." and writeVaryings(Varyings)) and surface_tissue.frag
// ("in vec3 vLt; ..." and readVaryings()).
std::string varyingDeclarations(bool vertexStage);

// Throws InternalError naming the first active uniform of a uFrame, uMaterial,
// uProcedural or uCamera struct that the tables lack, or whose GL type differs from
// the table's (`name`: the program, for the message).
void checkActiveUniforms(GLuint program, const std::string& name);

}  // namespace mucosa::render
