# render: OpenGL 3.3 core renderer, headless EGL contexts, the GLFW/Dear ImGui
# viewer, scenes. GLSL under shaders/ is embedded into the library at build
# time (embed_shaders.cmake), so the tool runs from any directory.
set(OpenGL_GL_PREFERENCE GLVND)
find_package(OpenGL REQUIRED COMPONENTS OpenGL EGL)

file(GLOB mucosa_shader_files CONFIGURE_DEPENDS
  ${PROJECT_SOURCE_DIR}/shaders/*.glsl ${PROJECT_SOURCE_DIR}/shaders/*.vert ${PROJECT_SOURCE_DIR}/shaders/*.frag)
list(SORT mucosa_shader_files)
set(mucosa_embedded_shaders ${PROJECT_BINARY_DIR}/generated/embedded_shaders.cpp)
add_custom_command(
  OUTPUT ${mucosa_embedded_shaders}
  COMMAND ${CMAKE_COMMAND} -DOUT=${mucosa_embedded_shaders} "-DSHADERS=${mucosa_shader_files}"
          -P ${CMAKE_CURRENT_LIST_DIR}/embed_shaders.cmake
  DEPENDS ${mucosa_shader_files} ${CMAKE_CURRENT_LIST_DIR}/embed_shaders.cmake
  COMMENT "Embedding GLSL shaders"
  VERBATIM)

file(GLOB mucosa_render_sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_LIST_DIR}/*.cpp)
target_sources(mucosa_render PRIVATE ${mucosa_render_sources} ${mucosa_embedded_shaders})
target_link_libraries(mucosa_render PRIVATE OpenGL::OpenGL OpenGL::EGL)

# The viewer: GLFW (window, X11) and Dear ImGui. Debian's libimgui-dev ships
# a static libimgui.a (position-independent) with the GLFW and OpenGL 3
# backends; its OpenGL loader dlopen()s libGL.
find_package(glfw3 CONFIG REQUIRED)
find_library(MUCOSA_IMGUI_LIBRARY imgui REQUIRED)
find_path(MUCOSA_IMGUI_INCLUDE_DIR imgui.h PATH_SUFFIXES imgui REQUIRED)
# Debian builds imgui against the stb package (imgui.pc: Requires: stb) for
# its font rasteriser.
find_library(MUCOSA_STB_LIBRARY stb REQUIRED)
target_include_directories(mucosa_render PRIVATE ${MUCOSA_IMGUI_INCLUDE_DIR})
target_link_libraries(mucosa_render PRIVATE glfw $<BUILD_INTERFACE:${MUCOSA_IMGUI_LIBRARY}> ${MUCOSA_STB_LIBRARY}
  ${CMAKE_DL_LIBS})
