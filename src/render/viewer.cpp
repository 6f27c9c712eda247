#include <mucosa/render/viewer.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "render/gl.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <mucosa/image/png.hpp>
#include <mucosa/reflectance/normal_map.hpp>
#include <mucosa/render/context.hpp>
#include <mucosa/render/renderer.hpp>

namespace mucosa::render {

namespace {

struct GlfwSession {
    GlfwSession() {
        if (!glfwInit()) throw GraphicsError("window", "", "GLFW cannot start (is there an X server? try xvfb-run)");
    }
    ~GlfwSession() { glfwTerminate(); }
};

camera::Vec3 add(const camera::Vec3& a, const camera::Vec3& b, float s) {
    return {a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]};
}
camera::Vec3 cross(const camera::Vec3& a, const camera::Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
camera::Vec3 normalized(const camera::Vec3& a) {
    const float l = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    return l > 0 ? camera::Vec3{a[0] / l, a[1] / l, a[2] / l} : a;
}

// Rotates `v` about unit axis `k` by angle `a` (Rodrigues).
camera::Vec3 rotate(const camera::Vec3& v, const camera::Vec3& k, float a) {
    const float c = std::cos(a), s = std::sin(a);
    const camera::Vec3 kxv = cross(k, v);
    const float kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    return {v[0] * c + kxv[0] * s + k[0] * kv * (1 - c), v[1] * c + kxv[1] * s + k[1] * kv * (1 - c),
            v[2] * c + kxv[2] * s + k[2] * kv * (1 - c)};
}

image::Image8 regenerateMap(const reflectance::MapParams& p) {
    const image::ImageF h = reflectance::heightField(p);
    return reflectance::encodeNormals8(h, p.strength,
                                       p.noise.tileable ? reflectance::Edges::Wrap : reflectance::Edges::Clamp);
}

}  // namespace

std::string viewerControls() {
    return "Space: play/pause the fly-through   W/S: forward/back   A/D: left/right   Q/E: down/up\n"
           "Right mouse drag: look around   Shift: faster   1-9, 0: shading modes 1-10   G: procedural\n"
           "X: specular anti-aliasing on/off   O: procedural noise in texture/object space   P: screenshot   "
           "Esc: quit";
}

ViewerReport runViewer(scene::Scene scene, scene::SceneAssets assets, const ViewerOptions& o) {
    GlfwSession glfw;
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    GLFWwindow* window = glfwCreateWindow(o.width, o.height, "mucosa view", nullptr, nullptr);
    if (window == nullptr) throw GraphicsError("window", "", "cannot open an OpenGL 3.3 core window");
    glfwMakeContextCurrent(window);
    glfwSwapInterval(o.vsync ? 1 : 0);

    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForOpenGL(window, true);
    ImGui_ImplOpenGL3_Init("#version 330 core");

    ViewerReport report;
    report.glRenderer = glRenderer();
    {
        Renderer renderer;
        renderer.setMesh(assets.mesh);
        if (!assets.diffuse.empty())
            renderer.setTexture(TextureSlot::Diffuse, assets.diffuse, scene.filter, shading::Wrap::Repeat);
        renderer.setTexture(TextureSlot::Reflectance, assets.reflectanceMap, scene.filter, shading::Wrap::Repeat);

        std::vector<camera::Pose> path;
        try {
            path = scene::cameraPoses(scene, assets, std::max(2, o.pathFrames));
        } catch (const InputError&) {
            path.assign(1, scene.pose.value_or(camera::Pose{}));
        }
        camera::Pose pose = path.front();
        bool playing = o.autoplay && path.size() > 1;
        double pathPos = 0.0;    // index into path, fractional
        float playSpeed = 1.0f;  // path frames per displayed frame
        reflectance::MapParams mapParams = scene.mapParams;
        bool mapDirty = false;
        int mode = static_cast<int>(scene.mode);
        double lastX = 0, lastY = 0;
        bool dragging = false;
        int shots = 0;
        std::array<bool, GLFW_KEY_LAST + 1> keyWasDown{};
        const auto pressed = [&](int key) {  // down now, up last frame
            const bool down = glfwGetKey(window, key) == GLFW_PRESS;
            const bool edge = down && !keyWasDown[static_cast<std::size_t>(key)];
            keyWasDown[static_cast<std::size_t>(key)] = down;
            return edge;
        };
        const auto start = std::chrono::steady_clock::now();
        auto last = start;

        while (!glfwWindowShouldClose(window)) {
            glfwPollEvents();
            const auto now = std::chrono::steady_clock::now();
            const float dt = std::min(0.1f, std::chrono::duration<float>(now - last).count());
            last = now;
            ImGuiIO& io = ImGui::GetIO();

            // Navigation (ignored while ImGui has the keyboard or mouse).
            if (!io.WantCaptureKeyboard) {
                if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Space))) playing = !playing && path.size() > 1;
                if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Escape))) glfwSetWindowShouldClose(window, 1);
                for (int k = 0; k < 10 && k < shading::kModeCount; ++k)
                    if (glfwGetKey(window, k == 9 ? GLFW_KEY_0 : GLFW_KEY_1 + k) == GLFW_PRESS) mode = k;
                if (glfwGetKey(window, GLFW_KEY_G) == GLFW_PRESS) mode = static_cast<int>(shading::Mode::Procedural);
                if (pressed(GLFW_KEY_X)) scene.specularAA = !scene.specularAA;
                if (pressed(GLFW_KEY_O))
                    scene.noiseSpace = scene.noiseSpace == shading::NoiseSpace::Uv ? shading::NoiseSpace::Object
                                                                                   : shading::NoiseSpace::Uv;
                const float speed = (glfwGetKey(window, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS ? 60.0f : 15.0f) * dt;
                const camera::Vec3 f = normalized(pose.forward);
                const camera::Vec3 r = normalized(cross(f, pose.up));
                const camera::Vec3 u = normalized(cross(r, f));
                const auto held = [&](int key) { return glfwGetKey(window, key) == GLFW_PRESS; };
                camera::Vec3 p = pose.position;
                if (held(GLFW_KEY_W)) p = add(p, f, speed);
                if (held(GLFW_KEY_S)) p = add(p, f, -speed);
                if (held(GLFW_KEY_D)) p = add(p, r, speed);
                if (held(GLFW_KEY_A)) p = add(p, r, -speed);
                if (held(GLFW_KEY_E)) p = add(p, u, speed);
                if (held(GLFW_KEY_Q)) p = add(p, u, -speed);
                if (p != pose.position) playing = false, pose.position = p;
                if (held(GLFW_KEY_P)) {
                    // Screenshot of the 3D view alone, next to the working directory.
                    int w = 0, h = 0;
                    glfwGetFramebufferSize(window, &w, &h);
                    Framebuffer fb(w, h);
                    fb.bind();
                    shading::FrameSetup fs = scene::frameSetup(scene, pose, w, h);
                    fs.mode = static_cast<shading::Mode>(mode);
                    renderer.draw(fs);
                    image::writePng(fmt::format("mucosa_view_{:04d}.png", shots++), fb.readRgb());
                    glBindFramebuffer(GL_FRAMEBUFFER, 0);
                }
            }
            if (!io.WantCaptureMouse) {
                double x = 0, y = 0;
                glfwGetCursorPos(window, &x, &y);
                if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) {
                    if (dragging) {
                        const float yaw = -static_cast<float>(x - lastX) * 0.004f;
                        const float pitch = -static_cast<float>(y - lastY) * 0.004f;
                        const camera::Vec3 f = normalized(pose.forward);
                        const camera::Vec3 r = normalized(cross(f, pose.up));
                        pose.forward = rotate(rotate(f, normalized(pose.up), yaw), r, pitch);
                        pose.up = normalized(cross(r, normalized(pose.forward)));
                        if (yaw != 0 || pitch != 0) playing = false;
                    }
                    dragging = true;
                } else {
                    dragging = false;
                }
                lastX = x, lastY = y;
            }
            if (playing) {
                pathPos += playSpeed;
                if (pathPos >= static_cast<double>(path.size() - 1)) pathPos = 0.0;
                pose = path[static_cast<std::size_t>(pathPos)];
            }

            ImGui_ImplOpenGL3_NewFrame();
            ImGui_ImplGlfw_NewFrame();
            ImGui::NewFrame();
            ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
            ImGui::SetNextWindowSize(ImVec2(360, static_cast<float>(o.height) - 20), ImGuiCond_FirstUseEver);
            ImGui::Begin("Mucosa");
            ImGui::Text("%.1f fps (%.2f ms)", io.Framerate, 1000.0f / std::max(io.Framerate, 1e-3f));
            ImGui::TextWrapped("%s", report.glRenderer.c_str());
            ImGui::Text("%zu / %zu triangles drawn", renderer.lastDrawnTriangles(), renderer.triangleCount());
            if (ImGui::BeginCombo("mode", std::string(shading::modeName(static_cast<shading::Mode>(mode))).c_str())) {
                for (int k = 0; k < shading::kModeCount; ++k) {
                    const auto m = static_cast<shading::Mode>(k);
                    if (ImGui::Selectable(std::string(shading::modeName(m)).c_str(), k == mode)) mode = k;
                    if (ImGui::IsItemHovered())
                        ImGui::SetTooltip("%s", std::string(shading::modeDescription(m)).c_str());
                }
                ImGui::EndCombo();
            }
            ImGui::Checkbox("specular anti-aliasing (X)", &scene.specularAA);
            if (ImGui::IsItemHovered())
                ImGui::SetTooltip("map: Toksvig on the mip chain; procedural: octaves fade at the pixel footprint");
            {
                int space = scene.noiseSpace == shading::NoiseSpace::Object ? 1 : 0;
                ImGui::Text("procedural noise (O):");
                ImGui::SameLine();
                ImGui::RadioButton("texture", &space, 0);
                ImGui::SameLine();
                ImGui::RadioButton("object", &space, 1);
                scene.noiseSpace = space == 1 ? shading::NoiseSpace::Object : shading::NoiseSpace::Uv;
            }
            if (path.size() > 1) {
                ImGui::Checkbox("fly through", &playing);
                ImGui::SameLine();
                ImGui::SliderFloat("speed", &playSpeed, 0.1f, 8.0f, "%.1f", ImGuiSliderFlags_Logarithmic);
            }
            // Every registry parameter, grouped as in scene files.
            for (const char* group : {"material", "light", "brdf"}) {
                if (!ImGui::CollapsingHeader(group, std::string(group) == "brdf" ? 0 : ImGuiTreeNodeFlags_DefaultOpen))
                    continue;
                for (const shading::ParamInfo& pi : shading::registry()) {
                    if (pi.group != group) continue;
                    const std::string label(pi.name);
                    float* v = scene.params.data(pi.id);
                    if (pi.components == 3) {
                        ImGui::ColorEdit3(label.c_str(), v);
                    } else {
                        const bool wide = pi.min > 0 && pi.max / pi.min > 100.0f;
                        ImGui::SliderFloat(label.c_str(), v, pi.min, wide ? std::min(pi.max, pi.min * 1e4f) : pi.max,
                                           "%.3g",
                                           (wide ? ImGuiSliderFlags_Logarithmic : 0) | ImGuiSliderFlags_AlwaysClamp);
                    }
                    if (ImGui::IsItemHovered())
                        ImGui::SetTooltip("%s%s%s", std::string(pi.description).c_str(), pi.unit.empty() ? "" : " [",
                                          pi.unit.empty() ? "" : (std::string(pi.unit) + "]").c_str());
                }
            }
            if (ImGui::CollapsingHeader("reflectance map")) {
                // A slider for each map parameter the registry gives one, over its range.
                for (const reflectance::MapParamInfo& i : reflectance::mapRegistry()) {
                    if (i.sliderMax <= i.sliderMin) continue;
                    const std::string label(i.name);
                    const double now = reflectance::get(mapParams, i.id);
                    nlohmann::json value;
                    if (i.kind == reflectance::MapParamKind::Integer) {
                        int v = static_cast<int>(now);
                        if (ImGui::SliderInt(label.c_str(), &v, static_cast<int>(i.sliderMin),
                                             static_cast<int>(i.sliderMax), "%d", ImGuiSliderFlags_AlwaysClamp))
                            value = v;
                    } else {
                        float v = static_cast<float>(now);
                        // Whole frequencies keep a tileable map tileable.
                        const bool whole = i.id == reflectance::MapParam::Frequency;
                        if (ImGui::SliderFloat(label.c_str(), &v, static_cast<float>(i.sliderMin),
                                               static_cast<float>(i.sliderMax), whole ? "%.0f" : "%.4f",
                                               ImGuiSliderFlags_Logarithmic | ImGuiSliderFlags_AlwaysClamp))
                            value = whole ? std::round(v) : v;
                    }
                    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", std::string(i.description).c_str());
                    if (!value.is_null()) {
                        reflectance::MapParams next = mapParams;
                        try {
                            reflectance::set(next, i.id, value, label);
                            reflectance::validate(next);
                            mapParams = next;
                            mapDirty = true;
                        } catch (const InputError&) {
                            // a value the map cannot take (e.g. octaves beyond the frequency limit): keep the last
                        }
                    }
                }
                ImGui::TextDisabled(
                    "(the map is regenerated when the slider is released;\n the procedural mode follows live)");
            }
            ImGui::TextWrapped("%s", viewerControls().c_str());
            ImGui::End();
            ImGui::Render();
            if (mapDirty && !ImGui::IsMouseDown(0)) {
                mapParams.size = std::min(mapParams.size, 1024);
                renderer.setTexture(TextureSlot::Reflectance, regenerateMap(mapParams), scene.filter,
                                    shading::Wrap::Repeat);
                mapDirty = false;
            }

            int w = 0, h = 0;
            glfwGetFramebufferSize(window, &w, &h);
            glBindFramebuffer(GL_FRAMEBUFFER, 0);
            glViewport(0, 0, w, h);
            if (w > 0 && h > 0) {
                scene.mapParams.noise = mapParams.noise;  // the procedural mode's parameters, live
                scene.mapParams.strength = mapParams.strength;
                shading::FrameSetup fs = scene::frameSetup(scene, pose, w, h);
                fs.mode = static_cast<shading::Mode>(mode);
                renderer.draw(fs);
            }
            ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
            ++report.frames;
            const bool last = o.maxFrames > 0 && report.frames >= o.maxFrames;
            if (last && o.screenshot) {
                glFinish();
                std::vector<std::uint8_t> rgba(static_cast<std::size_t>(w) * h * 4);
                glPixelStorei(GL_PACK_ALIGNMENT, 1);
                glReadBuffer(GL_BACK);
                glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
                image::Image8 img(w, h, 3);
                for (int y = 0; y < h; ++y)
                    for (int x = 0; x < w; ++x)
                        for (int c = 0; c < 3; ++c)
                            img.at(x, y, c) = rgba[(static_cast<std::size_t>(h - 1 - y) * w + x) * 4 + c];
                image::writePng(*o.screenshot, img);
            }
            glfwSwapBuffers(window);
            if (last) glfwSetWindowShouldClose(window, 1);
        }
        const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        report.meanFps = report.frames / std::max(secs, 1e-9);
    }
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    glfwDestroyWindow(window);
    return report;
}

}  // namespace mucosa::render
