#include <mucosa/register/patient.hpp>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/mesh/phantom.hpp>
#include <mucosa/mesh/tangents.hpp>
#include <mucosa/mesh/uv.hpp>
#include <mucosa/register/register.hpp>
#include <mucosa/render/offscreen.hpp>
#include <mucosa/scene/scene.hpp>
#include <mucosa/shading/reference.hpp>

#include "frames/frames_json.hpp"

namespace mucosa::registration {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr const char* kLobarBronchus = "right main bronchus.major";
constexpr double kPi = 3.14159265358979323846;

// The truth's rho(gamma) delta(r) (Category4): Lambertian with a little
// back-scatter, and the non-increasing cubic delta closest (in log intensity)
// to a lamp's (z_min^2 + a^2) / (z^2 + a^2) between z = 3 and 40 mm: a cubic
// cannot follow an inverse square over a range of 13 (docs/theory.md).
shading::BrdfParams truthBrdf() {
    shading::BrdfParams b;
    b.c = {0.05, 0.95, 0.0, 0.0};
    b.d = {-2.98, 2.98, -0.99};
    b.zmin = 3.0;
    b.zmax = 40.0;
    return b;
}

// A deterministic uniform deviate in [0, 1) (splitmix64: the same on every platform).
double uniform(std::uint64_t& state) {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-53;
}

scene::Scene patientScene(const PatientOptions& o, int branch) {
    scene::Scene s = scene::defaultScene();
    s.path.branch = branch;
    // Dense poses 0.1 mm apart along the bronchoscopist's flight; the frames
    // are picked from them by the schedule (forward, pauses, pull-backs).
    s.path.fly.speedMm = 0.1f;
    s.path.fly.startMm = static_cast<float>(o.startMm);
    s.path.fly.stopMm = static_cast<float>(o.stopMm);
    s.path.stopMm = static_cast<float>(o.stopMm);  // not the scene's default (the lumen's end radius)
    s.path.survey = false;
    s.path.fly.wander = 0.3f;
    s.path.fly.lookAroundDeg = 15.0f;
    s.path.fly.wallClearanceMm = 1.5f;
    s.path.fly.wanderPeriodMm = 40.0f;
    s.path.fly.seed = o.seed;
    // The plainer fine texture registration is measured on (docs/theory.md,
    // "A synthetic patient"): pq reads the default look's 0.2-0.4 mm stipple
    // and stronger mottle as shape.
    s.appearance.tissue.mottle = 2.4;
    s.appearance.tissue.stipple = 0.0;
    if (o.look == PatientLook::Category4) {
        using P = shading::Param;
        const shading::BrdfParams b = truthBrdf();
        s.mode = shading::Mode::BrdfNoise;
        s.params.set(P::C0, static_cast<float>(b.c[0]));
        s.params.set(P::C1, static_cast<float>(b.c[1]));
        s.params.set(P::C2, static_cast<float>(b.c[2]));
        s.params.set(P::C3, static_cast<float>(b.c[3]));
        s.params.set(P::D1, static_cast<float>(b.d[0]));
        s.params.set(P::D2, static_cast<float>(b.d[1]));
        s.params.set(P::D3, static_cast<float>(b.d[2]));
        s.params.set(P::DepthMin, static_cast<float>(b.zmin));
        s.params.set(P::DepthMax, static_cast<float>(b.zmax));
        s.params.set(P::Ambient, 0.0f);
        s.params.set(P::MucusOpacity, 0.0f);
    }
    for (const auto& [param, value] : o.params) s.params.set(param, value);
    return s;
}

// Rotates `v` about the unit axis `k` by `angle` (Rodrigues).
mesh::Vec3 rotate(const mesh::Vec3& v, const mesh::Vec3& k, double angle) {
    const double c = std::cos(angle), s = std::sin(angle);
    const double d = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    const mesh::Vec3 x{k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2], k[0] * v[1] - k[1] * v[0]};
    mesh::Vec3 r;
    for (int i = 0; i < 3; ++i) r[i] = static_cast<float>(v[i] * c + x[i] * s + k[i] * d * (1 - c));
    return r;
}

// Arc position (in dense-pose steps, 0..last) of every frame at `speed` steps
// per frame: forward, and with pauses: every 75 frames, 50 forward, 8 still,
// 10 back at half speed, 7 still. At the path's end the scope turns back.
std::vector<double> schedule(int frames, bool pauses, double speed, double last) {
    std::vector<double> pace(static_cast<std::size_t>(frames), 1.0);
    if (pauses)
        for (int t = 0; t < frames; ++t) {
            const int k = t % 75;
            pace[static_cast<std::size_t>(t)] = k < 50 ? 1.0 : k < 58 ? 0.0 : k < 68 ? -0.5 : 0.0;
        }
    std::vector<double> at(static_cast<std::size_t>(frames), 0.0);
    for (int t = 1; t < frames; ++t)
        at[static_cast<std::size_t>(t)] = at[static_cast<std::size_t>(t - 1)] + pace[static_cast<std::size_t>(t - 1)];
    // Where the path ends before the schedule does, the scope is withdrawn
    // along it, as a bronchoscopist does, rather than held still at the end
    // (which on a CT path can face the wall for the rest of the sequence).
    for (double& a : at) {
        a = std::max(0.0, a * speed);
        if (last > 0) {
            a = std::fmod(a, 2 * last);
            if (a > last) a = 2 * last - a;
        }
        a = std::clamp(a, 0.0, last);
    }
    return at;
}

// The endoscope's camera (shaders/camera.glsl) on an 8-bit linear render:
// exposure x jitter, vignetting, Poisson-Gaussian noise, clipping, the tone
// curve, 8 bits, the circular field-of-view mask.
image::Image8 applyCamera(const image::Image8& linear, const frames::CameraModel& cam, const shading::ParamSet& params,
                          double gain, int index) {
    using P = shading::Param;
    const double fullWell = params[P::FullWell], readNoise = params[P::ReadNoise];
    const double radius = params[P::MaskRadius] * 0.5 * std::min(cam.K.width, cam.K.height);
    std::uint64_t rng = 0x9e3779b97f4a7c15ULL * static_cast<std::uint64_t>(index + 1);
    image::Image8 out(linear.width(), linear.height(), 3);
    for (int y = 0; y < linear.height(); ++y)
        for (int x = 0; x < linear.width(); ++x) {
            const double vignette = cam.response.vignette(cam.K, x, y);
            const double dx = x - cam.K.cx, dy = y - cam.K.cy;
            const bool inside = dx * dx + dy * dy <= radius * radius;
            for (int c = 0; c < 3; ++c) {
                const double s = linear.at(x, y, c) / 255.0 * gain * vignette;
                // Box-Muller from two deviates.
                const double u1 = std::max(1e-300, uniform(rng)), u2 = uniform(rng);
                const double g = std::sqrt(-2 * std::log(u1)) * std::cos(2 * kPi * u2);
                const double noisy = s + std::sqrt((fullWell > 0 ? s / fullWell : 0.0) + readNoise * readNoise) * g;
                const double shown =
                    inside ? shading::toneCurve(static_cast<float>(std::clamp(noisy, 0.0, 1.0)), cam.response.toneCurve)
                           : 0.0;
                out.at(x, y, c) = static_cast<std::uint8_t>(std::lround(255.0 * shown));
            }
        }
    return out;
}

}  // namespace

SyntheticPatient makeSyntheticPatient(const PatientOptions& o) {
    if (o.frames < 2 || o.frames > 100000) throw InputError("frames", "", "must be between 2 and 100000");
    if (o.size < 32 || o.size > 4096) throw InputError("size", "", "must be between 32 and 4096 pixels");
    if (!(o.fovDeg >= 30 && o.fovDeg <= 150)) throw InputError("fov", "", "must be between 30 and 150 degrees");
    if (!(o.speedMm > 0 && o.speedMm <= 20)) throw InputError("speed", "", "must be in (0, 20] mm per frame");
    if (!(o.exposureJitter >= 0 && o.exposureJitter < 1)) throw InputError("exposure jitter", "", "must be in [0, 1)");
    SyntheticPatient p;
    p.options = o;
    p.brdf = truthBrdf();
    scene::Scene s;
    scene::SceneAssets assets;
    if (o.meshFile.empty()) {
        p.branch = kLobarBronchus;
        const scene::Scene probe = scene::defaultScene();
        mesh::PhantomParams pp;
        pp.generations = probe.mesh.phantomGenerations;
        pp.seed = probe.mesh.phantomSeed;
        pp.resolution = probe.mesh.phantomResolution;
        const mesh::Centerline tree = mesh::phantomCenterline(pp);
        int branch = -1;
        for (std::size_t b = 0; b < tree.branches.size(); ++b)
            if (tree.branches[b].name == kLobarBronchus) branch = static_cast<int>(b);
        if (branch < 0) throw InputError("phantom", "", std::string("has no ") + kLobarBronchus);
        s = patientScene(o, branch);
        assets = scene::loadAssets(s, o.threads, false);
    } else {
        // A CT airway: its own centerline and centerline UVs (the texture
        // wraps around each branch), tangents for the method's map.
        mesh::Mesh m = mesh::load(o.meshFile);
        if (!m.hasNormals()) throw InputError("mesh", o.meshFile.string(), "has no normals (facing the lumen)");
        const mesh::CenterlineUvReport uv = mesh::computeCenterlineUvs(m);
        mesh::computeTangents(m, o.threads);
        s = patientScene(o, -1);
        scene::Scene textureOnly = s;  // the scene's generated tissue texture
        textureOnly.mesh.kind = scene::MeshKind::Tube;
        assets = scene::loadAssets(textureOnly, o.threads, false);
        assets.mesh = std::move(m);
        p.branch = scene::setFlightPath(assets, uv.centerline, -1, o.meshFile.string());
    }
    p.mesh = std::move(assets.mesh);
    p.texture = std::move(assets.diffuse);
    const float length = camera::pathLength(assets.centerline);
    const int dense = static_cast<int>(std::floor((length - o.startMm - o.stopMm) / 0.1)) + 1;
    if (dense < 10)
        throw InputError("start", "",
                         fmt::format("{} mm + stop {} mm leave no path in the {:.0f} mm to the {}", o.startMm, o.stopMm,
                                     length, p.branch));
    assets.mesh = {};
    std::vector<camera::Pose> path = scene::cameraPoses(s, assets, dense);

    p.camera.K.width = p.camera.K.height = o.size;
    p.camera.K.fx = p.camera.K.fy = 0.5 * o.size / std::tan(0.5 * o.fovDeg * kPi / 180.0);
    p.camera.K.cx = p.camera.K.cy = 0.5 * (o.size - 1);
    p.camera.response.toneCurve = static_cast<int>(s.params[shading::Param::ToneCurve]);
    p.camera.response.vignetting = s.params[shading::Param::Vignetting];
    p.camera.response.knee = s.params[shading::Param::Knee];
    p.camera.lightOffset = o.lightOffset;
    if (o.look == PatientLook::Lamp) {  // the patient-specific modes have delta(r) instead of a lamp
        p.camera.lamp.spread = s.params[shading::Param::LightSpread];
        p.camera.lamp.radiusMm = s.params[shading::Param::LightSourceRadius];
        p.camera.lamp.ambient = s.params[shading::Param::Ambient];
    }

    if (!o.meshFile.empty()) {
        // A centerline computed on a CT surface can leave the lumen (where
        // the segmentation's pieces meet with a gap, or at a cut end): every
        // millimetre of the path is checked as registration checks a first
        // pose, and the scope stops 2 mm before the first that fails.
        for (std::size_t i = 0; i < path.size(); i += 10) {
            const camera::Pose& q = path[i];
            const frames::Vec3d eye{q.position[0], q.position[1], q.position[2]};
            const frames::Mat4 pose =
                frames::lookAtPose(eye, {eye[0] + q.forward[0], eye[1] + q.forward[1], eye[2] + q.forward[2]},
                                   {q.up[0], q.up[1], q.up[2]});
            try {
                checkInitialView(p.mesh, p.camera.K, pose, o.lightOffset, o.meshFile.string(), "path");
            } catch (const InputError& e) {
                if (i < 30)
                    throw InputError("mesh", o.meshFile.string(),
                                     fmt::format("the path along its centerline leaves the lumen {:.1f} mm from "
                                                 "the start ({}): start elsewhere",
                                                 0.1 * static_cast<double>(i), e.reason()));
                // The last pose is then 1 mm before the last one that passed.
                path.resize(i - 19);
                p.pathStopMm = o.startMm + 0.1 * static_cast<double>(i - 20);
                break;
            }
        }
    }

    std::uint64_t rng = o.seed * 0x2545f4914f6cdd1dULL + 17;
    const std::vector<double> at = schedule(o.frames, o.pauses, o.speedMm / 0.1, static_cast<double>(path.size() - 1));
    for (int t = 0; t < o.frames; ++t) {
        const double a = at[static_cast<std::size_t>(t)];
        const std::size_t i0 = static_cast<std::size_t>(std::floor(a)), i1 = std::min(i0 + 1, path.size() - 1);
        const float w = static_cast<float>(a - static_cast<double>(i0));
        camera::Pose q;
        for (int k = 0; k < 3; ++k) {
            q.position[k] = (1 - w) * path[i0].position[k] + w * path[i1].position[k];
            q.forward[k] = (1 - w) * path[i0].forward[k] + w * path[i1].forward[k];
            q.up[k] = (1 - w) * path[i0].up[k] + w * path[i1].up[k];
        }
        const float fn =
            std::sqrt(q.forward[0] * q.forward[0] + q.forward[1] * q.forward[1] + q.forward[2] * q.forward[2]);
        for (float& c : q.forward) c /= fn;
        // The hand's roll: slow, with a faster wobble.
        const double roll =
            o.rollDeg * kPi / 180.0 * (std::sin(2 * kPi * t / 170.0) + 0.3 * std::sin(2 * kPi * t / 47.0 + 1.0));
        q.up = rotate(q.up, q.forward, roll);
        const frames::Vec3d eye{q.position[0], q.position[1], q.position[2]};
        p.poses.push_back(frames::lookAtPose(eye, {eye[0] + q.forward[0], eye[1] + q.forward[1], eye[2] + q.forward[2]},
                                             {q.up[0], q.up[1], q.up[2]}));
        p.exposureFactors.push_back(1.0 + o.exposureJitter * (2.0 * uniform(rng) - 1.0));
    }
    return p;
}

struct PatientVideo::Impl {
    const SyntheticPatient& patient;
    scene::Scene scene;
    scene::SceneAssets assets;
    std::unique_ptr<render::OffscreenSession> session;
};

PatientVideo::PatientVideo(const SyntheticPatient& patient) : impl_(std::make_unique<Impl>(Impl{patient, {}, {}, {}})) {
    impl_->scene = patientScene(patient.options, -1);
    impl_->assets.mesh = patient.mesh;
    impl_->assets.diffuse = patient.texture;
    // The reflectance map of the scene (the method's highlights).
    scene::Scene mapOnly = impl_->scene;
    mapOnly.mesh.kind = scene::MeshKind::Tube;
    impl_->assets.reflectanceMap = scene::loadAssets(mapOnly, patient.options.threads, true).reflectanceMap;
    impl_->session = std::make_unique<render::OffscreenSession>(impl_->scene, impl_->assets, patient.options.size,
                                                                patient.options.size);
}

PatientVideo::~PatientVideo() = default;

image::Image8 PatientVideo::frame(int index) {
    const SyntheticPatient& p = impl_->patient;
    if (index < 0 || index >= static_cast<int>(p.poses.size()))
        throw InputError("frame", "", fmt::format("{} is not a frame of the video (0..{})", index, p.poses.size() - 1));
    const frames::Mat4& c2w = p.poses[static_cast<std::size_t>(index)];
    shading::FrameSetup f = scene::frameSetup(impl_->scene, camera::Pose{}, p.options.size, p.options.size);
    f.view = frames::glViewMatrix(c2w);
    f.projection = frames::glProjectionMatrix(p.camera.K, impl_->scene.lens.nearMm, impl_->scene.lens.farMm);
    const frames::Vec3d eye = frames::cameraCentre(c2w), light = frames::transformPoint(c2w, p.camera.lightOffset);
    for (int k = 0; k < 3; ++k) {
        f.eye[static_cast<std::size_t>(k)] = static_cast<float>(eye[static_cast<std::size_t>(k)]);
        f.light[static_cast<std::size_t>(k)] = static_cast<float>(light[static_cast<std::size_t>(k)]);
    }
    f.frameIndex = index;
    const double jitter = p.exposureFactors[static_cast<std::size_t>(index)];
    if (shading::info(f.mode).photographic) {
        // Auto-exposure as the scope does it, then the jitter on top (its compensation).
        f.params.set(shading::Param::ExposureEv,
                     f.params[shading::Param::ExposureEv] + static_cast<float>(std::log2(jitter)));
        return impl_->session->renderFrame(f);
    }
    // The patient-specific modes write linear radiance (no camera: they are
    // what `mucosa categories` shows); the scope's camera is applied here.
    return applyCamera(impl_->session->renderFrame(f), p.camera, f.params, jitter, index);
}

std::array<double, 3> truthAlbedo(const SyntheticPatient& p, double u, double v) {
    const image::Image8& t = p.texture;
    // OpenGL's texture space: v = 1 at the image's first row (docs/theory.md, "Conventions").
    const double fx = (u - std::floor(u)) * t.width() - 0.5, fy = (1.0 - (v - std::floor(v))) * t.height() - 0.5;
    const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
    const double a = fx - x0, b = fy - y0;
    auto texel = [&](int x, int y, int c) {
        x = ((x % t.width()) + t.width()) % t.width();
        y = ((y % t.height()) + t.height()) % t.height();
        return shading::inverseToneCurve(static_cast<float>(t.at(x, y, c) / 255.0), 2);  // sRGB-encoded
    };
    std::array<double, 3> r{};
    for (int c = 0; c < 3; ++c)
        r[static_cast<std::size_t>(c)] = (1 - a) * (1 - b) * texel(x0, y0, c) + a * (1 - b) * texel(x0 + 1, y0, c) +
                                         (1 - a) * b * texel(x0, y0 + 1, c) + a * b * texel(x0 + 1, y0 + 1, c);
    return r;
}

void writeSyntheticPatient(const SyntheticPatient& p, const fs::path& dir, const PatientWriteOptions& o) {
    std::error_code ec;
    for (const fs::path& d : {dir, dir / "video", dir / "truth"}) {
        fs::create_directories(d, ec);
        if (ec) throw IoError("output folder", d.string(), ec.message());
    }
    mesh::save(p.mesh, dir / "airway.glb");
    json cam{{"units", "mm"},
             {"intrinsics", frames::intrinsicsJson(p.camera.K)},
             {"tone_curve", frames::toneCurveName(p.camera.response.toneCurve)},
             {"vignetting", p.camera.response.vignetting},
             {"light",
              {{"offset", p.camera.lightOffset},
               {"spread", p.camera.lamp.spread},
               {"source_radius_mm", p.camera.lamp.radiusMm},
               {"ambient", p.camera.lamp.ambient}}}};
    writeFileAtomic(dir / "camera.json", cam.dump(2) + "\n");
    // The user's first pose: the truth, off by a hand's placement.
    const double deg = o.initErrorDeg * kPi / 180.0, mm = o.initErrorMm;
    const double tn = std::sqrt(3.0), rn = std::sqrt(1.0 + 1.0 + 0.25);
    const frames::Mat4 init =
        perturbPose(p.poses.front(), {mm / tn, -mm / tn, mm / tn}, {deg / rn, deg / rn, -0.5 * deg / rn});
    const frames::Vec3d c = frames::cameraCentre(init);
    json pose{{"position", c},
              {"look_at", frames::Vec3d{c[0] + 10 * init[0][2], c[1] + 10 * init[1][2], c[2] + 10 * init[2][2]}},
              {"up", frames::Vec3d{-init[0][1], -init[1][1], -init[2][1]}}};
    writeFileAtomic(dir / "init.json", pose.dump(2) + "\n");

    frames::FrameSet truth;
    truth.response = p.camera.response;
    truth.lightOffset = p.camera.lightOffset;
    PatientVideo video(p);
    const int n = static_cast<int>(p.poses.size());
    for (int i = 0; i < n; ++i) {
        frames::Frame f;
        f.image = dir / "video" / fmt::format("frame_{:04}.png", i);
        f.K = p.camera.K;
        f.cameraToWorld = p.poses[static_cast<std::size_t>(i)];
        image::writePng(f.image, video.frame(i));
        truth.frames.push_back(f);
        if (o.progress) o.progress(i + 1, n);
    }
    frames::writeFrames(dir / "truth" / "frames.json", truth);
    json brdf = shading::toJson(p.brdf);
    writeFileAtomic(dir / "truth" / "brdf.json", brdf.dump(2) + "\n");
    image::writePng(dir / "truth" / "texture.png", p.texture);
}

}  // namespace mucosa::registration
