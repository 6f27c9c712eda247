// mucosa register: the pose of every frame of a bronchoscopy on the patient's
// airway mesh (pq-space 2D/3D registration, or the intensity baseline).
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/fit/fit.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/io.hpp>
#include <mucosa/register/register.hpp>
#include <mucosa/register/video.hpp>
#include <mucosa/shading/brdf.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

namespace fs = std::filesystem;

struct RegisterArgs {
    std::string mesh, video, camera, init, out, method = "pq", report, brdf, framesDir;
    std::vector<int> levels;
    std::vector<double> mapAgreement;  // empty: RegisterOptions' default
    std::vector<double> mapReach;      // empty: RegisterOptions' default
    int maxIterations = 12, reportSamples = 6, step = 1,
        noLumenSearch = -1;  // -1: not given (the method's default)
    std::size_t maxFrames = 0;
    double searchRadius = registration::InitialSearch{}.radiusMm, searchDegrees = registration::InitialSearch{}.degrees;
    double albedoFilter = 0.0, prediction = 1.0, motionPrior = registration::RegisterOptions{}.motionPrior,
           rollPrior = registration::RegisterOptions{}.rollPrior,
           albedoPrior = registration::RegisterOptions{}.albedoPrior,
           paintMin = -1,    // -1: not given (RegisterOptions' default)
        minSimilarity = -1,  // -1: not given (the method's default)
        minDepthRange = registration::RegisterOptions{}.minDepthRange;
    bool restart = false, noAlbedoMap = false, keepMapPose = false, noKeepMapPose = false;
};

// The frames of a video: the PNG files of a folder, sorted by name.
std::vector<fs::path> listFrames(const std::string& video) {
    std::vector<fs::path> frames;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(video, ec)) {
        std::string ext = e.path().extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
        if (e.is_regular_file() && ext == ".png") frames.push_back(e.path());
    }
    if (ec) throw IoError("video", video, ec.message());
    if (frames.empty()) throw InputError("video", video, "holds no .png frames");
    std::sort(frames.begin(), frames.end());
    return frames;
}

// Where the frames to register come from: a folder of PNGs, or a video file
// decoded with FFmpeg whose frames (every `step`-th, at most `limit`) are
// written as PNGs into `dir` as they are reached: the frames file refers to
// them, and `mucosa fit` reads them.
class FrameSource {
public:
    FrameSource(const RegisterArgs& a, const fs::path& out) {
        std::error_code ec;
        if (!fs::exists(a.video, ec)) throw IoError("video", a.video, "does not exist");
        limit_ = a.maxFrames > 0 ? a.maxFrames : std::numeric_limits<std::size_t>::max();
        step_ = static_cast<std::size_t>(a.step);
        if (fs::is_directory(a.video, ec)) {
            const std::vector<fs::path> all = listFrames(a.video);
            for (std::size_t k = 0; k < all.size() && names_.size() < limit_; k += step_) names_.push_back(all[k]);
            return;
        }
        video_ = std::make_unique<registration::VideoReader>(a.video);
        dir_ = a.framesDir.empty() ? out.parent_path() / (out.stem().string() + "_frames") : fs::path(a.framesDir);
        const registration::VideoInfo& v = video_->info();
        if (v.frameCount > 0)
            estimate_ = std::min(limit_, (static_cast<std::size_t>(v.frameCount) + step_ - 1) / step_);
    }
    bool isVideo() const noexcept { return video_ != nullptr; }
    const registration::VideoInfo& videoInfo() const { return video_->info(); }
    const fs::path& framesDir() const noexcept { return dir_; }
    // Frames to register: exact for a folder, the container's estimate for a
    // video (0: unknown).
    std::size_t total() const noexcept { return video_ ? estimate_ : names_.size(); }
    // The path frame i is registered from (a video's, before it is written).
    fs::path name(std::size_t i) const {
        return video_ ? dir_ / fmt::format("frame_{:06}.png", i * step_) : names_.at(i);
    }
    // Frame i (called for i = 0, 1, 2, ... in order): its PNG, written from
    // the video when it is missing or `rewrite`; nothing past the end.
    std::optional<fs::path> get(std::size_t i, bool rewrite) {
        if (!video_) return i < names_.size() ? std::optional<fs::path>(names_[i]) : std::nullopt;
        if (i >= limit_) return std::nullopt;
        const std::int64_t want = static_cast<std::int64_t>(i * step_);
        while (video_->framesRead() <= want)
            if (!video_->next(rgb_)) return std::nullopt;
        const fs::path p = name(i);
        std::error_code ec;
        if (rewrite || !fs::exists(p, ec)) image::writePng(p, rgb_);
        return p;
    }

private:
    std::vector<fs::path> names_;
    std::unique_ptr<registration::VideoReader> video_;
    fs::path dir_;
    std::size_t step_ = 1, limit_ = 0, estimate_ = 0;
    image::Image8 rgb_;
};

void run(const RegisterArgs& a, const Global& g) {
    registration::RegisterOptions o;
    if (a.method == "pq")
        o.method = registration::RegistrationMethod::PqSpace;
    else if (a.method == "intensity")
        o.method = registration::RegistrationMethod::Intensity;
    else
        throw InputError("--method", "", "must be pq or intensity, got '" + a.method + "'");
    if (!a.levels.empty()) o.levels = a.levels;
    o.maxIterations = a.maxIterations;
    o.albedoFilterPx = a.albedoFilter;
    o.motionPrior = a.motionPrior;
    o.rollPrior = a.rollPrior;
    o.albedoPrior = a.albedoPrior;
    if (a.keepMapPose && a.noAlbedoMap)
        throw InputError("--keep-map-pose", "", "keeps the albedo map's pose, and --no-albedo-map turns the map off");
    if (a.keepMapPose && a.noKeepMapPose)
        throw InputError("--keep-map-pose", "", "and --no-keep-map-pose contradict each other");
    if (a.noKeepMapPose) o.keepMapPose = false;
    if (a.minSimilarity >= 0)
        (o.method == registration::RegistrationMethod::PqSpace ? o.minSimilarity : o.minCorrelation) = a.minSimilarity;
    o.minDepthRange = a.minDepthRange;
    if (a.noLumenSearch >= 0) o.noLumenSearch.candidates = a.noLumenSearch;
    if (a.paintMin >= 0) {
        if (a.noAlbedoMap)
            throw InputError("--paint-min", "",
                             "sets which frames paint the albedo map, and --no-albedo-map turns it off");
        o.minPaintSimilarity = a.paintMin;
    }
    if (!a.mapAgreement.empty()) {
        if (a.noAlbedoMap)
            throw InputError("--map-agreement", "",
                             "compares with the albedo map's pose, and --no-albedo-map turns "
                             "the map off");
        o.mapAgreementMm = a.mapAgreement[0];
        o.mapAgreementDegrees = a.mapAgreement[1];
    }
    if (!a.mapReach.empty()) {
        if (a.noAlbedoMap)
            throw InputError("--map-reach", "", "limits the albedo map's step, and --no-albedo-map turns the map off");
        o.mapReachMm = a.mapReach[0];
        o.mapReachDegrees = a.mapReach[1];
    }
    o.threads = g.threads;
    const fs::path out = a.out;
    if (out.extension() != ".json") throw InputError("--output", a.out, "must end in .json (a frames file)");
    requireWritable(out);
    if (!a.report.empty()) requireOutputDir(a.report);

    // Everything is checked before anything is written.
    const frames::CameraModel cam = frames::readCamera(a.camera);
    o.lightOffset = cam.lightOffset;
    o.lamp = cam.lamp;
    if (!a.brdf.empty()) o.brdf = shading::readBrdf(a.brdf);
    if (!(cam.K.cx >= 0 && cam.K.cx <= cam.K.width - 1 && cam.K.cy >= 0 && cam.K.cy <= cam.K.height - 1))
        throw InputError("field 'intrinsics.cx/cy'", a.camera,
                         fmt::format("the principal point ({}, {}) lies outside the {}x{} image", cam.K.cx, cam.K.cy,
                                     cam.K.width, cam.K.height));
    const frames::Mat4 init = frames::readPose(a.init);
    FrameSource source(a, out);
    if (source.isVideo()) {
        const registration::VideoInfo& v = source.videoInfo();
        if (v.width != cam.K.width || v.height != cam.K.height)
            throw InputError(
                "frame size", a.video,
                fmt::format("is {}x{}, but {} says {}x{}", v.width, v.height, a.camera, cam.K.width, cam.K.height));
        requireOutputDir(source.framesDir());
        // The frames' PNGs: about half their raw size, where the container says how many.
        if (source.total() > 0)
            requireDisk(saturatingMul(source.total(), static_cast<std::uint64_t>(v.width) * v.height * 3 / 2 + 4096),
                        source.framesDir(), "the video's frames");
    } else {
        for (std::size_t i = 0; i < source.total(); ++i) {
            const fs::path f = source.name(i);
            const image::PngHeader png = image::readPngHeader(f);  // the header only: frames are decoded once, later
            if (png.width != cam.K.width || png.height != cam.K.height)
                throw InputError(
                    "frame size", f.string(),
                    fmt::format("is {}x{}, but {} says {}x{}{}", png.width, png.height, a.camera, cam.K.width,
                                cam.K.height, i == 0 ? "" : " (and the first frame agrees with it)"));
        }
    }
    const mesh::Mesh m = mesh::load(a.mesh);
    registration::checkInitialView(m, cam.K, init, cam.lightOffset, a.mesh, a.init);

    // Resume: frames already registered in OUT (same method, same frames) are kept.
    registration::RegistrationRun run;
    run.camera = cam;
    run.method = o.method;
    run.mesh = a.mesh;
    run.albedoMap = !a.noAlbedoMap;
    std::error_code ec;
    if (fs::exists(out, ec) && !a.restart) {
        registration::RegistrationRun old;
        try {
            old = registration::readRegistration(out);
        } catch (const Error& e) {
            throw InputError("--output", a.out,
                             "exists and is not a registration to resume (" + e.reason() +
                                 "): choose another file, or pass --restart to overwrite it");
        }
        bool same = old.method == o.method && old.albedoMap == run.albedoMap &&
                    (source.isVideo() || old.frames.size() <= source.total());
        for (std::size_t i = 0; same && i < old.frames.size(); ++i)
            same =
                fs::absolute(old.frames[i].image).lexically_normal() == fs::absolute(source.name(i)).lexically_normal();
        if (!same)
            throw InputError("--output", a.out,
                             "holds a registration of other frames, by another method or with the albedo map "
                             "set otherwise (--no-albedo-map): pass --restart to overwrite it");
        run.frames = std::move(old.frames);
        if (!run.frames.empty())
            info(g, fmt::format("resuming: {} already registered in {}", count(run.frames.size(), "frame"), a.out));
    }

    const bool tty = ::isatty(STDERR_FILENO) != 0 && !g.quiet;
    const auto t0 = std::chrono::steady_clock::now();
    auto lastWrite = t0;
    // The track: resumed from the frames already registered.
    registration::Tracker tracker(init, a.prediction);
    for (const auto& f : run.frames) tracker.update(f.r);
    const std::size_t first = run.frames.size();
    // The albedo learnt along the track (on by default): resumed by adding
    // the kept frames again at their registered poses.
    registration::AlbedoMap map(m.vertexCount());
    auto prepare = [&](const fs::path& image) {
        frames::Frame fr;
        fr.image = image;
        fr.K = cam.K;
        image::Image8 sat;
        const image::ImageF linear = fit::loadFrameImage(fr, cam.response, &sat, o.saturation);
        return registration::prepareFrame(linear, &sat, cam.K, o);
    };
    registration::InitialSearch search;
    search.radiusMm = a.searchRadius;
    search.degrees = a.searchDegrees;
    if (source.isVideo()) {
        std::error_code mk;
        fs::create_directories(source.framesDir(), mk);
        if (mk) throw IoError("frames folder", source.framesDir().string(), mk.message());
        // Decode past the frames already registered (their PNGs are kept, or written again if missing).
        for (std::size_t i = 0; i < first; ++i)
            if (!source.get(i, false))
                throw InputError("video", a.video,
                                 fmt::format("ends after {} frames, but {} holds {} registered", i, a.out, first));
    }
    if (run.albedoMap && first > 0) {
        // Each kept frame is read and prepared again (tens of ms a frame).
        info(g, fmt::format("albedo map: repainting from the {} kept", count(first, "frame")));
        for (std::size_t i = 0; i < first; ++i)
            if (registration::paintsAlbedoMap(run.frames[i].r, o))
                map.add(m, prepare(run.frames[i].image), run.frames[i].r.cameraToWorld, o);
        info(g, fmt::format("albedo map: rebuilt from {} ({:.0f} % of the mesh's vertices seen)",
                            count(map.frames(), "registered frame"), 100 * map.seenFraction()));
    }
    for (std::size_t i = first;; ++i) {
        const std::optional<fs::path> name = source.get(i, true);
        if (!name) break;
        const registration::VideoFrame vf = prepare(*name);
        // From the last converged pose moved on by the last converged
        // motion (a lost frame does not drag the track away), and after a
        // flagged frame also from where that frame ended; the better is kept.
        // The first frame from the given pose, which is rough: searched around it.
        const bool searched = i == 0 && search.radiusMm + search.degrees > 0;
        registration::AlbedoMap* learn = run.albedoMap ? &map : nullptr;
        const registration::FrameRegistration r = searched ? registration::registerInitial(m, vf, init, o, search)
                                                           : registration::registerTracked(m, vf, tracker, o, learn);
        if (searched) {
            tracker.update(r);
            if (learn && r.converged) learn->add(m, vf, r.cameraToWorld, o);
        }
        run.frames.push_back({*name, r});
        const auto now = std::chrono::steady_clock::now();
        if (std::chrono::duration<double>(now - lastWrite).count() > 2.0) {
            registration::writeRegistration(out, run);
            lastWrite = now;
        }
        if (!g.quiet) {
            // A video's length is the container's estimate: never below what is done.
            const std::size_t total = std::max(source.total(), i + 1);
            const double s = std::chrono::duration<double>(now - t0).count();
            const double per = s / static_cast<double>(i + 1 - first);
            const std::string line = fmt::format(
                "[register {}/{}{} {:.0f}%] {}: similarity {:.3f}{}, {:.2f} s/frame, ETA {}", i + 1,
                source.isVideo() ? "~" : "", total, 100.0 * static_cast<double>(i + 1) / static_cast<double>(total),
                name->filename().string(), r.similarity,
                r.converged      ? ""
                : r.noLumen      ? (r.searched ? " NOT CONVERGED (no lumen in view; moved by the search)"
                                               : " NOT CONVERGED (no lumen in view)")
                : r.mapDisagreed ? " NOT CONVERGED (the albedo map disagrees)"
                                 : " NOT CONVERGED",
                per, formatDuration(per * static_cast<double>(total - i - 1)));
            if (tty)
                std::fprintf(stderr, "\r%s\x1b[K", line.c_str());
            else if (!r.converged || (i + 1) % std::max<std::size_t>(1, total / 10) == 0 || i + 1 == total)
                std::fprintf(stderr, "%s\n", line.c_str());
        }
    }
    if (tty) std::fprintf(stderr, "\n");
    if (run.frames.empty()) throw InputError("video", a.video, "holds no frames");
    registration::writeRegistration(out, run);  // the last frames (or, with nothing new, this run's description)

    std::size_t converged = 0;
    std::vector<double> sims;
    double render = 0, similarity = 0, optimiser = 0;
    for (const auto& f : run.frames) {
        converged += f.r.converged ? 1 : 0;
        sims.push_back(f.r.similarity);
        render += f.r.renderSeconds, similarity += f.r.similaritySeconds, optimiser += f.r.optimiserSeconds;
    }
    std::sort(sims.begin(), sims.end());
    const std::size_t total = run.frames.size(), done = total - first;
    info(g, fmt::format("registered {} ({} converged) with method {}; median similarity {:.3f}", count(total, "frame"),
                        converged, registration::methodName(o.method), sims[sims.size() / 2]));
    if (done > 0)
        info(g, fmt::format("per frame: {:.2f} s rendering, {:.2f} s similarity, {:.2f} s optimiser",
                            render / static_cast<double>(done), similarity / static_cast<double>(done),
                            optimiser / static_cast<double>(done)));
    {
        // The pose's standard deviations (registration.pose_sd): the median
        // per axis over the frames that have one.
        std::array<std::vector<double>, 6> sd;
        for (const auto& f : run.frames)
            for (std::size_t k = 0; k < 6; ++k)
                if (!std::isnan(f.r.poseSd[k])) sd[k].push_back(f.r.poseSd[k]);
        if (!sd[0].empty()) {
            std::array<double, 6> med{};
            for (std::size_t k = 0; k < 6; ++k) {
                std::sort(sd[k].begin(), sd[k].end());
                med[k] = sd[k][sd[k].size() / 2];
            }
            info(g, fmt::format("pose sd, median over frames (camera axes x, y, z): {:.2f}, {:.2f}, {:.2f} mm; "
                                "{:.2f}, {:.2f}, {:.2f} deg (z: the roll)",
                                med[0], med[1], med[2], med[3], med[4], med[5]));
        }
    }
    if (converged < total) {
        const auto walls = static_cast<std::size_t>(
            std::count_if(run.frames.begin(), run.frames.end(), [](const auto& f) { return f.r.noLumen; }));
        const auto searched = static_cast<std::size_t>(std::count_if(
            run.frames.begin(), run.frames.end(), [](const auto& f) { return f.r.noLumen && f.r.searched; }));
        warn(fmt::format(
            "{} not converged{}: flagged in {} (registration.converged false); mucosa fit skips them",
            count(total - converged, "frame"),
            walls > 0 ? fmt::format(" ({} with no lumen in view, {} of them moved by the search)", walls, searched)
                      : std::string(),
            a.out));
    }
    if (!a.report.empty()) {
        registration::writeRegistrationReport(a.report, run, m, o, a.reportSamples);
        info(g, "wrote " + joinPath(a.report, "index.html"));
    }
    info(g, "wrote " + a.out);
}

void addRegisterCommand(CLI::App& app, Global& g) {
    auto a = std::make_shared<RegisterArgs>();
    CLI::App* c = app.add_subcommand(
        "register", "Register bronchoscope video to the patient's airway mesh (pq-space 2D/3D registration)");
    c->footer(
        "Example: mucosa register --mesh airway.glb --video frames/ --camera camera.json --init pose.json "
        "-o frames.json --report report/\n"
        "camera.json: {\"intrinsics\": {\"width\", \"height\", \"fx\", \"fy\", \"cx\", \"cy\", \"k1\", \"k2\"}, "
        "\"gamma\", \"light\": {\"offset\": [x, y, z]}}\n"
        "pose.json: {\"position\", \"look_at\", \"up\"} (mm, world) or {\"camera_to_world\": row-major 4x4}");
    c->add_option("--mesh", a->mesh, "The airway mesh, normals facing the lumen (any format `mucosa mesh` reads)")
        ->required();
    c->add_option("--video", a->video,
                  "The bronchoscopy: a video file (any FFmpeg reads: MP4, MKV, AVI, ...) or a folder of its frames "
                  "as PNG, in name order")
        ->required();
    c->add_option(
        "--frames-dir", a->framesDir,
        "Video file: folder for its frames as PNG, which the frames file refers to [OUTPUT's name + _frames]");
    c->add_option("--step", a->step, "Register every STEP-th frame [1]")->check(wholeNumber(1, 100000));
    c->add_option("--max-frames", a->maxFrames, "Register at most this many frames [all]");
    c->add_option("--camera", a->camera, "Camera file: intrinsics, distortion, gamma, light offset (JSON)")->required();
    c->add_option("--init", a->init, "The first frame's pose (JSON)")->required();
    c->add_option("-o,--output", a->out, "Frames file to write (the input of mucosa fit); resumed if it exists")
        ->required();
    c->add_option("--method", a->method, "pq (shape from shading, the paper's) or intensity (NCC baseline) [pq]");
    c->add_option("--brdf", a->brdf,
                  "Shade the model with a fitted brdf.json (mucosa fit) instead of the lamp model: for video whose "
                  "fall-off is not the lamp's inverse square");
    c->add_option("--report", a->report, "Folder for an HTML report: similarity trace, overlays, pq fields");
    c->add_option("--report-frames", a->reportSamples, "Frames shown in the report [6]")->check(wholeNumber(0, 1000));
    c->add_option("--levels", a->levels, "Working widths in pixels, coarse to fine [40 80]")
        ->check(wholeNumber(16, 4096));
    c->add_option("--max-iterations", a->maxIterations, "Optimiser iterations per level [12]")
        ->check(wholeNumber(1, 1000));
    c->add_option("--albedo-filter", a->albedoFilter,
                  "pq: radius (frame pixels) of an opening+closing removing vessels and glints [0 = off]")
        ->check(CLI::Range(0.0, 64.0));
    c->add_option("--motion-prediction", a->prediction,
                  "Start each frame from the last pose moved on by this fraction of the last motion [1; 0 = off]")
        ->check(CLI::Range(0.0, 2.0));
    c->add_option("--motion-prior", a->motionPrior,
                  "Weight of the prior holding each frame near its predicted pose (1 mm, 2 degrees), where the "
                  "frame leaves the pose free (roll in a round tube), e.g. 0.0005 [0 = off]")
        ->check(CLI::Range(0.0, 1.0));
    c->add_flag("--no-albedo-map", a->noAlbedoMap,
                "Track without the albedo learnt along the way (by default each frame is first moved by "
                "intensity against the model carrying the albedo the frames before it painted on the mesh)");
    c->add_option("--albedo-prior", a->albedoPrior,
                  "Weight holding the method's pose near the albedo map's (units of --motion-prior)")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    c->add_flag("--keep-map-pose", a->keepMapPose,
                "A frame the method does not converge on keeps the albedo map's pose (where that converged) as "
                "its estimate, still flagged, and the next frame starts there [on]");
    c->add_flag("--no-keep-map-pose", a->noKeepMapPose,
                "A frame the method does not converge on keeps where the method's own iterations ended");
    c->add_option(
         "--min-similarity", a->minSimilarity,
         fmt::format("A frame whose similarity at the end is below this is flagged not converged [pq {:.2f}, "
                     "intensity {:.2f}]",
                     registration::RegisterOptions{}.minSimilarity, registration::RegisterOptions{}.minCorrelation))
        ->check(CLI::Range(0.0, 1.0));
    c->add_option("--min-depth-range", a->minDepthRange,
                  "A frame whose view at the estimate reaches no farther than this many times its median depth "
                  "(the model's 99th depth percentile over its median: 5-20 down a bronchus) is flagged not "
                  "converged: it faces the wall with no lumen in view, where the shape fixes the pose least "
                  "[0 = off]")
        ->check(CLI::Range(0.0, 1000.0))
        ->capture_default_str();
    c->add_option(
         "--no-lumen-search", a->noLumenSearch,
         fmt::format("A frame with no lumen in view is searched for around the track: this many poses "
                     "within {:.0f} mm and {:.0f} degrees are scored, the best {} refined, and the "
                     "best-scoring pose kept (still flagged) [pq {}, intensity 0; 0 = off]",
                     registration::RegisterOptions{}.noLumenSearch.radiusMm,
                     registration::RegisterOptions{}.noLumenSearch.degrees,
                     registration::RegisterOptions{}.noLumenSearch.refine, registration::kNoLumenSearchCandidates))
        ->check(CLI::Range(0, 100000));
    c->add_option("--paint-min", a->paintMin,
                  fmt::format("A converged frame paints the albedo map only if its similarity is at least this "
                              "[{:.2f}; 0 = every converged frame]",
                              registration::RegisterOptions{}.minPaintSimilarity))
        ->check(CLI::Range(0.0, 1.0));
    c->add_option("--map-agreement", a->mapAgreement,
                  fmt::format("MM DEG: a frame the method converges on farther than this from the albedo map's "
                              "converged pose is flagged (neither painted nor fitted) [{} {}; 0 0 = off]",
                              registration::RegisterOptions{}.mapAgreementMm,
                              registration::RegisterOptions{}.mapAgreementDegrees))
        ->expected(2)
        ->check(CLI::Range(0.0, 1000.0));
    c->add_option(
         "--map-reach", a->mapReach,
         fmt::format("MM DEG: the albedo map's step counts only within this of where the frame started "
                     "(farther, it found another wall alike) [{} {}; 0 0 = off]",
                     registration::RegisterOptions{}.mapReachMm, registration::RegisterOptions{}.mapReachDegrees))
        ->expected(2)
        ->check(CLI::Range(0.0, 1000.0));
    c->add_option("--roll-prior", a->rollPrior,
                  fmt::format("Weight of the same prior on the roll alone (the rotation about the optical axis, 2 "
                              "degrees), which a round airway leaves free [{}; 0 = off]",
                              registration::RegisterOptions{}.rollPrior))
        ->check(CLI::Range(0.0, 1.0));
    c->add_option("--search-radius", a->searchRadius,
                  "First frame: search this far (mm) around --init, and --search-degrees of rotation, before "
                  "registering from the best poses [10; 0 with --search-degrees 0 = off]")
        ->check(CLI::Range(0.0, 100.0));
    c->add_option("--search-degrees", a->searchDegrees, "First frame: rotations searched around --init [20]")
        ->check(CLI::Range(0.0, 180.0));
    c->add_flag("--restart", a->restart, "Overwrite an existing output instead of resuming it");
    c->callback([a, &g] { run(*a, g); });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(68, addRegisterCommand);

}  // namespace mucosa::cli
