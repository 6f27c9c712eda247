#include <mucosa/render/viewer.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <utility>
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

namespace {

// The window and its ImGui, made and torn down in order.
class Window {
public:
    explicit Window(const ViewerOptions& o) {
        glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
        glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
        glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
        glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
        window_ = glfwCreateWindow(o.width, o.height, "mucosa view", nullptr, nullptr);
        if (window_ == nullptr) throw GraphicsError("window", "", "cannot open an OpenGL 3.3 core window");
        glfwMakeContextCurrent(window_);
        glfwSwapInterval(o.vsync ? 1 : 0);
        // Key presses arrive as events, so a press shorter than a frame is not
        // lost at 12-16 fps; installed before ImGui's, which chains to it.
        glfwSetWindowUserPointer(window_, &presses_);
        glfwSetKeyCallback(window_, [](GLFWwindow* w, int key, int, int action, int) {
            if (action == GLFW_PRESS) static_cast<std::vector<int>*>(glfwGetWindowUserPointer(w))->push_back(key);
        });
        IMGUI_CHECKVERSION();
        ImGui::CreateContext();
        ImGui::GetIO().IniFilename = nullptr;
        ImGui::StyleColorsDark();
        ImGui_ImplGlfw_InitForOpenGL(window_, true);
        ImGui_ImplOpenGL3_Init("#version 330 core");
    }
    ~Window() {
        ImGui_ImplOpenGL3_Shutdown();
        ImGui_ImplGlfw_Shutdown();
        ImGui::DestroyContext();
        glfwDestroyWindow(window_);
    }
    Window(const Window&) = delete;
    Window& operator=(const Window&) = delete;

    GLFWwindow* get() const noexcept { return window_; }
    // The keys pressed since the last call, in order (a held key repeats nothing).
    std::vector<int> takePresses() { return std::exchange(presses_, {}); }
    bool held(int key) const { return glfwGetKey(window_, key) == GLFW_PRESS; }

private:
    GLFWwindow* window_ = nullptr;
    std::vector<int> presses_;
};

// One viewer session: the scene, the camera and what the panel edits, and a
// phase per step of a frame.
class Viewer {
public:
    Viewer(scene::Scene scene, const scene::SceneAssets& assets, const ViewerOptions& o, Window& window)
        : scene_(std::move(scene)),
          o_(o),
          window_(window),
          mapParams_(scene_.mapParams),
          mode_(static_cast<int>(scene_.mode)) {
        renderer_.setMesh(assets.mesh);
        if (!assets.diffuse.empty())
            renderer_.setTexture(TextureSlot::Diffuse, assets.diffuse, scene_.filter, shading::Wrap::Repeat);
        renderer_.setTexture(TextureSlot::Reflectance, assets.reflectanceMap, scene_.filter, shading::Wrap::Repeat);
        try {
            path_ = scene::cameraPoses(scene_, assets, std::max(2, o.pathFrames));
        } catch (const InputError&) {
            path_.assign(1, scene_.pose.value_or(camera::Pose{}));
        }
        pose_ = path_.front();
        playing_ = o.autoplay && path_.size() > 1;
    }

    ViewerReport run(std::string glRendererName) {
        ViewerReport report;
        report.glRenderer = std::move(glRendererName);
        const auto start = std::chrono::steady_clock::now();
        auto last = start;
        while (!glfwWindowShouldClose(window_.get())) {
            glfwPollEvents();
            const auto now = std::chrono::steady_clock::now();
            const float dt = std::min(0.1f, std::chrono::duration<float>(now - last).count());
            last = now;
            handleKeys(dt);
            handleMouse();
            advancePath();
            drawPanel(report.glRenderer);
            regenerateMapIfDirty();
            const auto [w, h] = drawScene();
            ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
            ++report.frames;
            const bool lastFrame = o_.maxFrames > 0 && report.frames >= o_.maxFrames;
            if (lastFrame && o_.screenshot) image::writePng(*o_.screenshot, readWindow(w, h));
            glfwSwapBuffers(window_.get());
            if (lastFrame) glfwSetWindowShouldClose(window_.get(), 1);
        }
        const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        report.meanFps = report.frames / std::max(secs, 1e-9);
        return report;
    }

private:
    shading::FrameSetup frame(int w, int h) const {
        shading::FrameSetup fs = scene::frameSetup(scene_, pose_, w, h);
        fs.mode = static_cast<shading::Mode>(mode_);
        // A live camera: the sensor noise changes every frame and
        // auto-exposure adapts from one to the next.
        fs.frameIndex = drawn_;
        return fs;
    }

    // Presses (one action each, however short) and held keys (movement),
    // ignored while ImGui has the keyboard.
    void handleKeys(float dt) {
        const std::vector<int> presses = window_.takePresses();
        if (ImGui::GetIO().WantCaptureKeyboard) return;
        for (const int key : presses) {
            if (key == GLFW_KEY_SPACE) playing_ = !playing_ && path_.size() > 1;
            if (key == GLFW_KEY_ESCAPE) glfwSetWindowShouldClose(window_.get(), 1);
            if (key >= GLFW_KEY_1 && key <= GLFW_KEY_9 && key - GLFW_KEY_1 < shading::kModeCount)
                mode_ = key - GLFW_KEY_1;
            if (key == GLFW_KEY_0 && shading::kModeCount > 9) mode_ = 9;
            if (key == GLFW_KEY_G) mode_ = static_cast<int>(shading::Mode::Procedural);
            if (key == GLFW_KEY_X) scene_.specularAA = !scene_.specularAA;
            if (key == GLFW_KEY_O)
                scene_.noiseSpace = scene_.noiseSpace == shading::NoiseSpace::Uv ? shading::NoiseSpace::Object
                                                                                 : shading::NoiseSpace::Uv;
            if (key == GLFW_KEY_P) screenshot();  // one per press
        }
        const float speed = (window_.held(GLFW_KEY_LEFT_SHIFT) ? 60.0f : 15.0f) * dt;
        const camera::Vec3 f = normalized(pose_.forward);
        const camera::Vec3 r = normalized(cross(f, pose_.up));
        const camera::Vec3 u = normalized(cross(r, f));
        camera::Vec3 p = pose_.position;
        if (window_.held(GLFW_KEY_W)) p = add(p, f, speed);
        if (window_.held(GLFW_KEY_S)) p = add(p, f, -speed);
        if (window_.held(GLFW_KEY_D)) p = add(p, r, speed);
        if (window_.held(GLFW_KEY_A)) p = add(p, r, -speed);
        if (window_.held(GLFW_KEY_E)) p = add(p, u, speed);
        if (window_.held(GLFW_KEY_Q)) p = add(p, u, -speed);
        if (p != pose_.position) playing_ = false, pose_.position = p;
    }

    // The 3D view alone, next to the working directory.
    void screenshot() {
        int w = 0, h = 0;
        glfwGetFramebufferSize(window_.get(), &w, &h);
        if (w <= 0 || h <= 0) return;
        Framebuffer fb(w, h);
        fb.bind();
        renderer_.draw(frame(w, h));
        image::writePng(fmt::format("mucosa_view_{:04d}.png", shots_++), fb.readRgb());
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
    }

    // Right-drag looks around.
    void handleMouse() {
        if (ImGui::GetIO().WantCaptureMouse) return;
        double x = 0, y = 0;
        glfwGetCursorPos(window_.get(), &x, &y);
        if (glfwGetMouseButton(window_.get(), GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) {
            if (dragging_) {
                const float yaw = -static_cast<float>(x - lastX_) * 0.004f;
                const float pitch = -static_cast<float>(y - lastY_) * 0.004f;
                const camera::Vec3 f = normalized(pose_.forward);
                const camera::Vec3 r = normalized(cross(f, pose_.up));
                pose_.forward = rotate(rotate(f, normalized(pose_.up), yaw), r, pitch);
                pose_.up = normalized(cross(r, normalized(pose_.forward)));
                if (yaw != 0 || pitch != 0) playing_ = false;
            }
            dragging_ = true;
        } else {
            dragging_ = false;
        }
        lastX_ = x, lastY_ = y;
    }

    void advancePath() {
        if (!playing_) return;
        pathPos_ += playSpeed_;
        if (pathPos_ >= static_cast<double>(path_.size() - 1)) pathPos_ = 0.0;
        pose_ = path_[static_cast<std::size_t>(pathPos_)];
    }

    void drawPanel(const std::string& glRendererName) {
        ImGuiIO& io = ImGui::GetIO();
        ImGui_ImplOpenGL3_NewFrame();
        ImGui_ImplGlfw_NewFrame();
        ImGui::NewFrame();
        ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
        ImGui::SetNextWindowSize(ImVec2(360, static_cast<float>(o_.height) - 20), ImGuiCond_FirstUseEver);
        ImGui::Begin("Mucosa");
        ImGui::Text("%.1f fps (%.2f ms)", io.Framerate, 1000.0f / std::max(io.Framerate, 1e-3f));
        ImGui::TextWrapped("%s", glRendererName.c_str());
        ImGui::Text("%zu / %zu triangles drawn", renderer_.lastDrawnTriangles(), renderer_.triangleCount());
        modeControls();
        if (path_.size() > 1) {
            ImGui::Checkbox("fly through", &playing_);
            ImGui::SameLine();
            ImGui::SliderFloat("speed", &playSpeed_, 0.1f, 8.0f, "%.1f", ImGuiSliderFlags_Logarithmic);
        }
        shadingParameterControls();
        mapParameterControls();
        ImGui::TextWrapped("%s", viewerControls().c_str());
        ImGui::End();
        ImGui::Render();
    }

    void modeControls() {
        if (ImGui::BeginCombo("mode", std::string(shading::modeName(static_cast<shading::Mode>(mode_))).c_str())) {
            for (const shading::ModeInfo& m : shading::modes()) {
                const int k = static_cast<int>(m.id);
                if (ImGui::Selectable(std::string(m.name).c_str(), k == mode_)) mode_ = k;
                if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", std::string(m.description).c_str());
            }
            ImGui::EndCombo();
        }
        ImGui::Checkbox("specular anti-aliasing (X)", &scene_.specularAA);
        if (ImGui::IsItemHovered())
            ImGui::SetTooltip("map: Toksvig on the mip chain; procedural: octaves fade at the pixel footprint");
        int space = scene_.noiseSpace == shading::NoiseSpace::Object ? 1 : 0;
        ImGui::Text("procedural noise (O):");
        ImGui::SameLine();
        ImGui::RadioButton("texture", &space, 0);
        ImGui::SameLine();
        ImGui::RadioButton("object", &space, 1);
        scene_.noiseSpace = space == 1 ? shading::NoiseSpace::Object : shading::NoiseSpace::Uv;
    }

    // Every shading registry parameter, grouped as in scene files.
    void shadingParameterControls() {
        for (const char* group : {"material", "light", "brdf"}) {
            if (!ImGui::CollapsingHeader(group, std::string(group) == "brdf" ? 0 : ImGuiTreeNodeFlags_DefaultOpen))
                continue;
            for (const shading::ParamInfo& pi : shading::registry()) {
                if (pi.group != group) continue;
                const std::string label(pi.name);
                float* v = scene_.params.data(pi.id);
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
    }

    // A slider for each map parameter the map registry gives one, over its range.
    void mapParameterControls() {
        if (!ImGui::CollapsingHeader("reflectance map")) return;
        for (const reflectance::MapParamInfo& i : reflectance::mapRegistry()) {
            if (i.sliderMax <= i.sliderMin) continue;
            const std::string label(i.name);
            const double now = reflectance::get(mapParams_, i.id);
            nlohmann::json value;
            if (i.kind == reflectance::MapParamKind::Integer) {
                int v = static_cast<int>(now);
                if (ImGui::SliderInt(label.c_str(), &v, static_cast<int>(i.sliderMin), static_cast<int>(i.sliderMax),
                                     "%d", ImGuiSliderFlags_AlwaysClamp))
                    value = v;
            } else {
                float v = static_cast<float>(now);
                const bool whole = i.id == reflectance::MapParam::Frequency;  // whole frequencies keep maps tileable
                if (ImGui::SliderFloat(label.c_str(), &v, static_cast<float>(i.sliderMin),
                                       static_cast<float>(i.sliderMax), whole ? "%.0f" : "%.4f",
                                       ImGuiSliderFlags_Logarithmic | ImGuiSliderFlags_AlwaysClamp))
                    value = whole ? std::round(v) : v;
            }
            if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", std::string(i.description).c_str());
            if (value.is_null()) continue;
            reflectance::MapParams next = mapParams_;
            try {
                reflectance::set(next, i.id, value, label);
                reflectance::validate(next);
                mapParams_ = next;
                mapDirty_ = true;
            } catch (const InputError&) {
                // a value the map cannot take (octaves beyond the frequency limit): keep the last
            }
        }
        ImGui::TextDisabled("(the map is regenerated when the slider is released;\n the procedural mode follows live)");
    }

    void regenerateMapIfDirty() {
        if (!mapDirty_ || ImGui::IsMouseDown(0)) return;
        mapParams_.size = std::min(mapParams_.size, 1024);
        renderer_.setTexture(TextureSlot::Reflectance, regenerateMap(mapParams_), scene_.filter, shading::Wrap::Repeat);
        mapDirty_ = false;
    }

    // The 3D view into the window's back buffer; returns its size.
    std::pair<int, int> drawScene() {
        int w = 0, h = 0;
        glfwGetFramebufferSize(window_.get(), &w, &h);
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glViewport(0, 0, w, h);
        if (w > 0 && h > 0) {
            scene_.mapParams.noise = mapParams_.noise;  // the procedural mode's parameters, live
            scene_.mapParams.strength = mapParams_.strength;
            renderer_.draw(frame(w, h));
            ++drawn_;
        }
        return {w, h};
    }

    // The back buffer (3D view and panel), rows top first.
    static image::Image8 readWindow(int w, int h) {
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
        return img;
    }

    scene::Scene scene_;
    const ViewerOptions& o_;
    Window& window_;
    Renderer renderer_;
    std::vector<camera::Pose> path_;
    camera::Pose pose_;
    bool playing_ = false;
    double pathPos_ = 0.0;    // index into path_, fractional
    float playSpeed_ = 1.0f;  // path frames per displayed frame
    reflectance::MapParams mapParams_;
    bool mapDirty_ = false;
    int mode_ = 0;
    double lastX_ = 0, lastY_ = 0;
    bool dragging_ = false;
    int shots_ = 0;
    int drawn_ = 0;  // frames drawn to the window (the camera's frame index)
};

}  // namespace

// Phases: GLFW, the window (with ImGui and the key callback), the viewer
// (renderer, textures, camera path), the frame loop.
ViewerReport runViewer(scene::Scene scene, scene::SceneAssets assets, const ViewerOptions& o) {
    GlfwSession glfw;
    Window window(o);
    const std::string name = glRenderer();
    Viewer viewer(std::move(scene), assets, o, window);  // destroyed (GL objects freed) before the window
    return viewer.run(name);
}

}  // namespace mucosa::render
