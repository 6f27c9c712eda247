// The uniform tables (src/render/uniforms.hpp) against real linked programs:
// every program the renderer links passes the check (the parity tests draw
// with all of them); a struct member the tables lack, or a type that differs,
// fails by name.
#include <gtest/gtest.h>

#include <string>

#include <mucosa/core/error.hpp>
#include <mucosa/render/context.hpp>

#include "render/gl.hpp"
#include "render/shader.hpp"
#include "render/uniforms.hpp"
#include "render_test_support.hpp"

namespace mucosa {
namespace {

GLuint linkFragment(const std::string& fragmentBody) {
    return render::linkProgram("#version 330 core\nvoid main() { gl_Position = vec4(0.0, 0.0, 0.0, 1.0); }\n",
                               "#version 330 core\nout vec4 color;\n" + fragmentBody, "test");
}

std::string checkMessage(GLuint program) {
    try {
        render::checkActiveUniforms(program, "test");
    } catch (const InternalError& e) {
        return e.what();
    }
    return "";
}

TEST(UniformTables, NameTheFieldThatIsMissingOrOfAnotherType) {
    test::glContext();
    // The table's own fields with their types: accepted.
    const GLuint good = linkFragment(
        "struct Material { vec3 baseColor; float shininess; };\nuniform Material uMaterial;\n"
        "void main() { color = vec4(uMaterial.baseColor * uMaterial.shininess, 1.0); }\n");
    EXPECT_EQ(checkMessage(good), "");
    // A renamed member.
    const GLuint renamed = linkFragment(
        "struct Material { vec3 albedo; };\nuniform Material uMaterial;\n"
        "void main() { color = vec4(uMaterial.albedo, 1.0); }\n");
    {
        const std::string m = checkMessage(renamed);
        EXPECT_NE(m.find("'uMaterial.albedo' is not in the uniform tables"), std::string::npos) << m;
    }
    // The right name with another type.
    const GLuint retyped =
        linkFragment("struct Frame { vec4 eye; };\nuniform Frame uFrame;\nvoid main() { color = uFrame.eye; }\n");
    const std::string m = checkMessage(retyped);
    EXPECT_NE(m.find("uniform 'uFrame.eye' has GL type"), std::string::npos) << m;
    for (GLuint p : {good, renamed, retyped}) glDeleteProgram(p);
}

TEST(UniformTables, OffsetsAndTypesCoverEachStruct) {
    for (const auto& table : {render::frameUniforms(), render::materialUniforms(), render::proceduralUniforms(),
                              render::cameraUniforms()}) {
        ASSERT_FALSE(table.empty());
        std::size_t previous = 0;
        for (std::size_t i = 0; i < table.size(); ++i) {
            if (i > 0) {
                EXPECT_GT(table[i].offset, previous) << table[i].name;  // declaration order
            }
            previous = table[i].offset;
        }
    }
    EXPECT_EQ(render::cameraUniforms()[0].name, "uCamera.exposure");
    EXPECT_EQ(render::frameUniforms()[0].name, "uFrame.viewProj");
    EXPECT_EQ(render::materialUniforms()[0].name, "uMaterial.baseColor");
}

}  // namespace
}  // namespace mucosa
