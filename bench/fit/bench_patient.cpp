// Registration along the phantom's airway (register/patient.hpp): the synthetic
// patient's bronchoscopy from the lower trachea through the carina into the
// right main and lobar bronchi, with roll, pauses, pull-backs, sensor noise
// and the exposure jittered +-30 % frame to frame; the pq-space method and
// the intensity baseline on the same frames, tracking from a first pose 1 mm
// and 2 degrees off (what `mucosa demo` hands to `mucosa register`).
//   bench_patient [look=lamp|category4] [frames=300] [size=320] [start_mm=60] [model] [mesh]
// model: how registration shades the mesh: `lamp` (the lamp model, from
// camera.json) or `brdf` (the truth's rho(gamma) delta(z), as `mucosa register
// --brdf` with a fitted brdf.json); default: brdf for category4, lamp for lamp.
// mesh: a CT airway file instead of the phantom (tests/data/airway/...).
// MUCOSA_PRIOR=K sets RegisterOptions::motionPrior (default: the option's);
// MUCOSA_ROLL_PRIOR=K sets RegisterOptions::rollPrior;
// MUCOSA_SINGLE_START=1 tracks from the tracker's first start only (no retry
// from a flagged frame's estimate);
// MUCOSA_SEED=N draws another path, roll and noise (PatientOptions::seed);
// MUCOSA_PARAMS=name=value,... sets registry parameters on the video's look
// (PatientOptions::params; e.g. specular_strength=0,sheen_strength=0);
// MUCOSA_PQ_ONLY=1 runs pq alone, without the capture test;
// by default each run registers as `mucosa register` does: the first frame
// searched around the initial pose (registration::registerInitial), then tracked with
// an albedo learnt along the track (registration::AlbedoMap);
// MUCOSA_NO_SEARCH_FIRST=1 registers the first frame from the initial pose
// alone, MUCOSA_NO_ALBEDO_MAP=1 tracks without the map,
// MUCOSA_ALBEDO_PRIOR=K sets RegisterOptions::albedoPrior,
// MUCOSA_KEEP_MAP_POSE=0|1 sets RegisterOptions::keepMapPose,
// MUCOSA_PAINT_MIN=S sets RegisterOptions::minPaintSimilarity,
// MUCOSA_MIN_SIMILARITY=S sets RegisterOptions::minSimilarity,
// MUCOSA_MAP_AGREEMENT=MM,DEG sets RegisterOptions::mapAgreementMm and
// mapAgreementDegrees (0,0: off); MUCOSA_MAP_REACH=MM,DEG sets
// RegisterOptions::mapReachMm and mapReachDegrees (0,0: off); MUCOSA_ANCHOR=0|1 sets
// Tracker::anchorOnMap;
// MUCOSA_NO_LUMEN_SEARCH=N[,MM,DEG,REFINE,TIE] sets RegisterOptions::
// noLumenSearch (candidates, radius, degrees, refined, tie; N 0: off);
// MUCOSA_DUMP=DIR with MUCOSA_DUMP_FRAMES=a,b,... writes those frames'
// fields at the finest level as raw float32 (the video's luminance and pq
// field, the model's at the true and the estimated pose; see below);
// MUCOSA_KEEP_PATIENT=1 keeps the synthetic patient's folder (its video,
// truth, mesh and camera: what `mucosa register` takes) and prints its path;
// MUCOSA_TRACE=FILE writes one line per frame and method: frame, position
// and orientation error, similarity, converged, the viewing direction's
// error, then the albedo map step's position and orientation error (-1: it
// did not converge), then the method's similarity at the true pose (above
// the similarity reached: the optimiser stopped short of the truth; below
// it: the objective itself prefers the wrong pose), the position's error in
// the true camera's axes (x, y, z), and the similarity at the truth moved
// 5 mm along its x axis and at the truth turned 10 degrees about its y axis
// (what a wrong pose scores: the flag threshold's other side), the rotation's
// error about the true camera's x, y and z axes (degrees, z the roll), and
// the estimate's FrameRegistration::poseSd (x, y, z mm; x, y, z degrees).
// Prints per method: median and p95 position (mm) and orientation (degrees)
// error, losses (> 5 mm or > 10 degrees for more than 10 frames), frames
// flagged, seconds per frame split into renders, similarity and optimiser;
// the first frame's capture range; peak memory.
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <random>
#include <string>

#include <mucosa/fit/fit.hpp>
#include <mucosa/register/patient.hpp>
#include <mucosa/register/register.hpp>
#include <mucosa/shading/params.hpp>
#include <mucosa/shading/reference.hpp>

using namespace mucosa;
namespace fs = std::filesystem;

namespace {

// The model's depth over a frame's field of view at a pose (finest level):
// its 5th, 50th, 95th and 99th percentiles, mm (pixels beyond the rendered
// neighbourhood count at farMm). A view down a lumen spans a wide range, a
// wall seen face on a narrow one.
std::array<double, 4> viewDepths(const mesh::Mesh& m, const registration::VideoFrame::Level& lv,
                                 const frames::Mat4& pose, const registration::RegisterOptions& o) {
    const registration::ModelView v = registration::renderModel(m, lv.K, pose, o.lightOffset, 2, 1, o.lamp);
    std::vector<double> z;
    for (std::size_t i = 0; i < lv.valid.size(); ++i)
        if (lv.valid[i]) z.push_back(std::min<double>(v.depth.data()[i], o.farMm));  // inf: nothing hit
    std::array<double, 4> out{NAN, NAN, NAN, NAN};
    if (z.empty()) return out;
    std::sort(z.begin(), z.end());
    const double q[4] = {0.05, 0.5, 0.95, 0.99};
    for (int k = 0; k < 4; ++k) out[static_cast<std::size_t>(k)] = z[static_cast<std::size_t>(q[k] * (z.size() - 1))];
    return out;
}

// The rotation taking b's camera axes to a's, as a rotation vector in b's
// camera axes (degrees).
std::array<double, 3> rotationBetween(const frames::Mat4& a, const frames::Mat4& b) {
    double R[3][3];  // b^T a
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            R[i][j] = 0;
            for (int k = 0; k < 3; ++k) R[i][j] += b[k][i] * a[k][j];
        }
    const double angle = std::acos(std::clamp((R[0][0] + R[1][1] + R[2][2] - 1) / 2, -1.0, 1.0));
    const double v[3] = {R[2][1] - R[1][2], R[0][2] - R[2][0], R[1][0] - R[0][1]};
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (n < 1e-12) return {0, 0, 0};
    const double s = angle * 180 / M_PI / n;
    return {v[0] * s, v[1] * s, v[2] * s};
}

double quantile(std::vector<double> v, double q) {
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5))];
}

}  // namespace

int main(int argc, char** argv) {
    const std::string look = argc > 1 ? argv[1] : "lamp";
    registration::PatientOptions po;
    po.look = look == "lamp" ? registration::PatientLook::Lamp : registration::PatientLook::Category4;
    po.frames = argc > 2 ? std::atoi(argv[2]) : 300;
    po.size = argc > 3 ? std::atoi(argv[3]) : 320;
    po.startMm = argc > 4 ? std::atof(argv[4]) : 60.0;
    const std::string model = argc > 5 ? argv[5] : look == "lamp" ? "lamp" : "brdf";
    if (argc > 6) po.meshFile = argv[6];
    if (const char* k = std::getenv("MUCOSA_SEED")) po.seed = std::strtoull(k, nullptr, 10);
    // MUCOSA_PARAMS=name=value,...: registry parameters set on the video's
    // look (e.g. specular_strength=0 to take the highlights out).
    if (const char* k = std::getenv("MUCOSA_PARAMS")) {
        std::string list = k;
        for (std::size_t at = 0; at < list.size();) {
            const std::size_t end = std::min(list.find(',', at), list.size());
            const std::string item = list.substr(at, end - at);
            const std::size_t eq = item.find('=');
            const shading::ParamInfo* p = eq == std::string::npos ? nullptr : shading::findParam(item.substr(0, eq));
            if (!p) {
                std::fprintf(stderr, "error: MUCOSA_PARAMS: unknown parameter in '%s'\n", item.c_str());
                return 2;
            }
            po.params.emplace_back(p->id, std::strtof(item.c_str() + eq + 1, nullptr));
            at = end + 1;
        }
    }
    if ((look != "lamp" && look != "category4") || (model != "lamp" && model != "brdf") || po.frames < 2 ||
        po.size < 64) {
        std::fprintf(stderr, "usage: bench_patient [lamp|category4] [frames] [size] [start_mm] [lamp|brdf] [mesh]\n");
        return 2;
    }
    const registration::SyntheticPatient patient = registration::makeSyntheticPatient(po);
    const fs::path dir = fs::temp_directory_path() / ("mucosa_bench_patient_" + std::to_string(::getpid()));
    registration::writeSyntheticPatient(patient, dir);
    std::printf("%s: %zu triangles; %s look, %d frames %dx%d from %.0f mm to the %s; model shaded by the %s\n",
                po.meshFile.empty() ? "phantom" : po.meshFile.string().c_str(), patient.mesh.triangleCount(),
                look.c_str(), po.frames, po.size, po.size, po.startMm, patient.branch.c_str(),
                model == "lamp" ? "lamp model" : "truth's brdf");
    if (patient.pathStopMm > 0)
        std::printf("the centerline's path leaves the lumen: the scope stops at %.1f mm\n", patient.pathStopMm);
    const frames::FrameSet truth = frames::readFrames(dir / "truth" / "frames.json");
    const frames::Mat4 init = frames::readPose(dir / "init.json");
    std::vector<image::ImageF> linear;
    std::vector<image::Image8> sat(truth.frames.size());
    for (std::size_t i = 0; i < truth.frames.size(); ++i)
        linear.push_back(fit::loadFrameImage(truth.frames[i], truth.response, &sat[i], 0.97));
    std::fflush(stdout);

    auto modelTexture = std::make_shared<registration::ModelTexture>();
    {
        const image::Image8& t = patient.texture;
        modelTexture->luminance = image::ImageF(t.width(), t.height(), 1);
        modelTexture->wrap = true;
        for (int y = 0; y < t.height(); ++y)
            for (int x = 0; x < t.width(); ++x) {
                double l = 0;
                for (int c = 0; c < 3; ++c)
                    l += (c == 0   ? 0.2126
                          : c == 1 ? 0.7152
                                   : 0.0722) *
                         shading::inverseToneCurve(static_cast<float>(t.at(x, y, c) / 255.0), 2);
                modelTexture->luminance.at(x, y) = static_cast<float>(l);
            }
    }
    auto options = [&](registration::RegistrationMethod method) {
        registration::RegisterOptions o;
        o.method = method;
        o.lightOffset = truth.lightOffset;
        o.lamp = patient.camera.lamp;
        if (model == "brdf") o.brdf = patient.brdf;
        // MUCOSA_MODEL_TEXTURE=1: the model carries the truth's albedo (what
        // `mucosa register --fit` gives it from a fitted texture; an oracle here).
        if (std::getenv("MUCOSA_MODEL_TEXTURE")) o.texture = modelTexture;
        if (const char* k = std::getenv("MUCOSA_PRIOR")) o.motionPrior = std::atof(k);
        if (const char* k = std::getenv("MUCOSA_ROLL_PRIOR")) o.rollPrior = std::atof(k);
        if (const char* k = std::getenv("MUCOSA_ALBEDO_PRIOR")) o.albedoPrior = std::atof(k);
        if (const char* k = std::getenv("MUCOSA_KEEP_MAP_POSE")) o.keepMapPose = std::atoi(k) != 0;
        if (const char* k = std::getenv("MUCOSA_PAINT_MIN")) o.minPaintSimilarity = std::atof(k);
        if (const char* k = std::getenv("MUCOSA_MIN_SIMILARITY")) o.minSimilarity = std::atof(k);
        if (const char* k = std::getenv("MUCOSA_MAP_AGREEMENT"))
            std::sscanf(k, "%lf,%lf", &o.mapAgreementMm, &o.mapAgreementDegrees);
        if (const char* k = std::getenv("MUCOSA_MAP_REACH"))
            std::sscanf(k, "%lf,%lf", &o.mapReachMm, &o.mapReachDegrees);
        if (const char* k = std::getenv("MUCOSA_NO_LUMEN_SEARCH"))
            std::sscanf(k, "%d,%lf,%lf,%d,%lf", &o.noLumenSearch.candidates, &o.noLumenSearch.radiusMm,
                        &o.noLumenSearch.degrees, &o.noLumenSearch.refine, &o.noLumenSearch.tie);
        return o;
    };
    FILE* trace = std::getenv("MUCOSA_TRACE") ? std::fopen(std::getenv("MUCOSA_TRACE"), "w") : nullptr;
    const bool pqOnly = std::getenv("MUCOSA_PQ_ONLY") != nullptr;
    const bool singleStart = std::getenv("MUCOSA_SINGLE_START") != nullptr;
    // One tracked run: its statistics printed, its registrations returned.
    // An albedo learnt along the track (registration::AlbedoMap; off: MUCOSA_NO_ALBEDO_MAP=1).
    const bool online = std::getenv("MUCOSA_NO_ALBEDO_MAP") == nullptr;
    auto track = [&](const registration::RegisterOptions& o, const char* label) {
        registration::AlbedoMap map(patient.mesh.vertexCount());
        std::vector<registration::FrameRegistration> out;
        std::vector<double> mm, deg;
        double render = 0, similarity = 0, optimiser = 0, wall = 0;
        int converged = 0, losses = 0, lostFor = 0;
        registration::Tracker tracker(init, 1.0);
        if (const char* k = std::getenv("MUCOSA_ANCHOR")) tracker.anchorOnMap = std::atoi(k) != 0;
        for (std::size_t i = 0; i < truth.frames.size(); ++i) {
            const auto t0 = std::chrono::steady_clock::now();
            const registration::VideoFrame vf = registration::prepareFrame(linear[i], &sat[i], patient.camera.K, o);
            registration::FrameRegistration r;
            if (i == 0 && !std::getenv("MUCOSA_NO_SEARCH_FIRST")) {
                // The first frame as `mucosa register` takes it: searched
                // around the initial pose (registration::registerInitial).
                r = registration::registerInitial(patient.mesh, vf, init, o);
                tracker.update(r);
                if (online && r.converged) map.add(patient.mesh, vf, r.cameraToWorld, o);
            } else if (singleStart) {
                r = registration::registerFrame(patient.mesh, vf, tracker.start(), tracker.options(o));
                tracker.update(r);
            } else {
                r = registration::registerTracked(patient.mesh, vf, tracker, o, online ? &map : nullptr);
            }
            out.push_back(r);
            wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            render += r.renderSeconds, similarity += r.similaritySeconds, optimiser += r.optimiserSeconds;
            converged += r.converged;
            const registration::PoseError e = registration::poseError(r.cameraToWorld, truth.frames[i].cameraToWorld);
            mm.push_back(e.position);
            deg.push_back(e.degrees);
            if (trace) {
                // The viewing direction's error alone (the rest of e.degrees is roll about it).
                const frames::Mat4& a = r.cameraToWorld;
                const frames::Mat4& b = truth.frames[i].cameraToWorld;
                const double dot = a[0][2] * b[0][2] + a[1][2] * b[1][2] + a[2][2] * b[2][2];
                // Then the albedo map's step: its pose's error (-1: it did not converge).
                registration::PoseError m{-1, -1};
                if (r.mapConverged) m = registration::poseError(r.mapCameraToWorld, b);
                registration::RegisterOptions atTruth = o;
                atTruth.maxIterations = 0;
                atTruth.recheck = false;
                const double truthSimilarity = registration::registerFrame(patient.mesh, vf, b, atTruth).similarity;
                // And at two wrong poses: the truth moved 5 mm sideways, and turned 10 degrees.
                const double offSimilarity[2] = {
                    registration::registerFrame(patient.mesh, vf, registration::perturbPose(b, {5, 0, 0}, {0, 0, 0}),
                                                atTruth)
                        .similarity,
                    registration::registerFrame(
                        patient.mesh, vf, registration::perturbPose(b, {0, 0, 0}, {0, 10 * M_PI / 180, 0}), atTruth)
                        .similarity};
                // The position's error in the true camera's axes (x right, y down, z forward).
                double off[3] = {0, 0, 0};
                for (int c = 0; c < 3; ++c)
                    for (int k = 0; k < 3; ++k) off[c] += b[k][c] * (a[k][3] - b[k][3]);
                // The rotation's error about the true camera's axes (a small-angle
                // rotation vector, degrees; the last is the roll).
                const std::array<double, 3> w = rotationBetween(a, b);
                // The view's depths at the estimate and at the truth (columns 25-28, 29-32).
                const std::array<double, 4> de = viewDepths(patient.mesh, vf.levels.back(), a, o);
                const std::array<double, 4> dt = viewDepths(patient.mesh, vf.levels.back(), b, o);
                std::fprintf(
                    trace,
                    "%s %zu %.3f %.3f %.4f %d %.3f %.3f %.3f %.4f %.3f %.3f %.3f %.4f %.4f %.3f %.3f %.3f %.3f "
                    "%.3f %.3f %.3f %.3f %.3f %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f\n",
                    label, i, e.position, e.degrees, r.similarity, r.converged ? 1 : 0,
                    std::acos(std::clamp(dot, -1.0, 1.0)) * 180 / M_PI, m.position, m.degrees, truthSimilarity, off[0],
                    off[1], off[2], offSimilarity[0], offSimilarity[1], w[0], w[1], w[2], r.poseSd[0], r.poseSd[1],
                    r.poseSd[2], r.poseSd[3], r.poseSd[4], r.poseSd[5], de[0], de[1], de[2], de[3], dt[0], dt[1], dt[2],
                    dt[3]);
            }
            if (const char* dumpDir = std::getenv("MUCOSA_DUMP")) {
                // MUCOSA_DUMP=DIR with MUCOSA_DUMP_FRAMES=a,b,...: the finest
                // level's fields of those frames as raw float32 files (width
                // x height, row-major): the video's luminance, p, q, weight;
                // the model's p, q, weight at the true and at the estimated pose.
                const std::string list = std::string(",") +
                                         (std::getenv("MUCOSA_DUMP_FRAMES") ? std::getenv("MUCOSA_DUMP_FRAMES") : "") +
                                         ",";
                if (list.find("," + std::to_string(i) + ",") != std::string::npos && !vf.levels.empty()) {
                    const registration::VideoFrame::Level& lv = vf.levels.back();
                    auto raw = [&](const std::string& name, const float* v, std::size_t n) {
                        FILE* f = std::fopen(
                            (fs::path(dumpDir) / (label + std::string("_") + std::to_string(i) + "_" + name + ".f32"))
                                .c_str(),
                            "wb");
                        if (f) std::fwrite(v, sizeof(float), n, f), std::fclose(f);
                    };
                    const std::size_t n = static_cast<std::size_t>(lv.K.width) * lv.K.height;
                    raw("lum", lv.luminance.data(), n);
                    std::vector<float> valid(lv.valid.begin(), lv.valid.end());
                    raw("valid", valid.data(), n);
                    raw("vp", lv.pq.p.data(), n), raw("vq", lv.pq.q.data(), n), raw("vw", lv.pq.weight.data(), n);
                    const frames::Mat4* poses[2] = {&truth.frames[i].cameraToWorld, &r.cameraToWorld};
                    const char* names[2] = {"t", "e"};
                    for (int k = 0; k < 2; ++k) {
                        const registration::ModelView mv =
                            registration::renderModel(patient.mesh, lv.K, *poses[k], o.lightOffset, 2, o.supersample,
                                                      o.lamp, o.brdf ? &*o.brdf : nullptr, o.texture.get());
                        const registration::PqField m =
                            registration::pqFromModel(mv, lv.K, lv.pqOptions, &lv.pq.usable);
                        raw(std::string(names[k]) + "p", m.p.data(), n),
                            raw(std::string(names[k]) + "q", m.q.data(), n);
                        raw(std::string(names[k]) + "w", m.weight.data(), n),
                            raw(std::string(names[k]) + "s", mv.shading.data(), n);
                    }
                    std::printf("dumped frame %zu (%dx%d)\n", i, lv.K.width, lv.K.height);
                }
            }
            lostFor = (e.position > 5 || e.degrees > 10) ? lostFor + 1 : 0;
            if (lostFor == 11) ++losses;
        }
        const double n = static_cast<double>(truth.frames.size());
        if (online)
            std::printf("albedo map: %zu frames, %.0f %% of the vertices seen\n", map.frames(),
                        100 * map.seenFraction());
        std::printf(
            "%-9s position median %.2f mm p95 %.2f mm | orientation median %.2f deg p95 %.2f deg | %d/%zu converged, "
            "%d losses | %.2f s/frame (renders %.2f, similarity %.2f, optimiser %.2f)\n",
            label, quantile(mm, 0.5), quantile(mm, 0.95), quantile(deg, 0.5), quantile(deg, 0.95), converged,
            truth.frames.size(), losses, wall / n, render / n, similarity / n, optimiser / n);
        std::fflush(stdout);
        return out;
    };
    std::vector<registration::FrameRegistration> pqRun;
    for (registration::RegistrationMethod method :
         {registration::RegistrationMethod::PqSpace, registration::RegistrationMethod::Intensity}) {
        if (pqOnly && method != registration::RegistrationMethod::PqSpace) continue;
        if (std::getenv("MUCOSA_INTENSITY_ONLY") && method != registration::RegistrationMethod::Intensity) continue;
        auto r = track(options(method), registration::methodName(method));
        if (method == registration::RegistrationMethod::PqSpace) pqRun = std::move(r);
    }
    // MUCOSA_PIPELINE=1: the patient pipeline's second pass. The texture is
    // fitted from pq's poses (converged frames; mucosa fit), then every frame
    // is registered again by intensity against the model carrying that
    // texture (mucosa register --fit).
    if (std::getenv("MUCOSA_PIPELINE") && !pqRun.empty()) {
        frames::FrameSet registered = truth;
        registered.frames.clear();
        for (std::size_t i = 0; i < truth.frames.size(); ++i)
            if (pqRun[i].converged) {
                frames::Frame f = truth.frames[i];
                f.cameraToWorld = pqRun[i].cameraToWorld;
                registered.frames.push_back(f);
            }
        const auto t0 = std::chrono::steady_clock::now();
        const fit::FitResult fitted = fit::fitFrames(patient.mesh, registered, fit::FitOptions{});
        std::printf("fitted the texture from %zu pq-registered frames in %.1f s (%.0f %% of the atlas seen)\n",
                    registered.frames.size(),
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                    100 * fitted.coveredFraction);
        auto tex = std::make_shared<registration::ModelTexture>(
            registration::modelTexture(fitted.texture, fitted.uvMin, fitted.uvMax));
        registration::RegisterOptions o = options(registration::RegistrationMethod::Intensity);
        o.texture = tex;
        track(o, "intensity, fitted texture");
        o = options(registration::RegistrationMethod::PqSpace);
        o.texture = tex;
        track(o, "pq, fitted texture");
    }

    if (trace) std::fclose(trace);
    // Capture range of the first frame: 2, 5, 10 mm with 5, 10, 20 degrees,
    // 6 random directions each; success = within 1 mm and 2 degrees.
    std::mt19937 dirRng(3);
    std::normal_distribution<double> g(0, 1);
    const frames::Mat4& first = truth.frames[0].cameraToWorld;
    for (registration::RegistrationMethod method :
         {registration::RegistrationMethod::PqSpace, registration::RegistrationMethod::Intensity}) {
        if (pqOnly) break;
        const registration::RegisterOptions o = options(method);
        const registration::VideoFrame vf = registration::prepareFrame(linear[0], &sat[0], patient.camera.K, o);
        std::printf("%-9s capture:", registration::methodName(method));
        for (const auto& [emm, edeg] : {std::pair{2.0, 5.0}, std::pair{5.0, 10.0}, std::pair{10.0, 20.0}}) {
            int ok = 0;
            const int tries = 6;
            for (int t = 0; t < tries; ++t) {
                frames::Vec3d a{g(dirRng), g(dirRng), g(dirRng)}, b{g(dirRng), g(dirRng), g(dirRng)};
                const double na = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
                const double nb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
                for (int k = 0; k < 3; ++k) a[k] *= emm / na, b[k] *= edeg * M_PI / 180 / nb;
                const registration::FrameRegistration r =
                    registration::registerFrame(patient.mesh, vf, registration::perturbPose(first, a, b), o);
                const registration::PoseError e = registration::poseError(r.cameraToWorld, first);
                ok += e.position < 1 && e.degrees < 2;
            }
            std::printf(" %.0f mm/%.0f deg: %d/%d", emm, edeg, ok, tries);
        }
        std::printf("\n");
    }
    std::error_code ec;
    if (std::getenv("MUCOSA_KEEP_PATIENT"))
        std::printf("the synthetic patient is kept in %s\n", dir.string().c_str());
    else
        fs::remove_all(dir, ec);
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    std::printf("peak memory %.0f MB\n", static_cast<double>(ru.ru_maxrss) / 1024.0);
    return 0;
}
