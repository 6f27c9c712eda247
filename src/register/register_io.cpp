// `mucosa register`'s files: the registered frames file (resumable), the
// starting-view checks, and the HTML report.
#include <mucosa/register/register.hpp>

#include <algorithm>
#include <cmath>
#include <regex>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/text.hpp>
#include <mucosa/core/version.hpp>
#include <mucosa/fit/fit.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/mesh/analysis.hpp>

#include "core/json_parse.hpp"
#include "frames/frames_json.hpp"

namespace mucosa::registration {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {}  // namespace

void writeRegistration(const fs::path& path, const RegistrationRun& run) {
    const fs::path folder = path.parent_path();
    const json k = frames::intrinsicsJson(run.camera.K);
    json j{{"units", "mm"},
           {"light", {{"offset", run.camera.lightOffset}}},
           {"registration",
            {{"method", methodName(run.method)},
             {"mesh", run.mesh},
             {"albedo_map", run.albedoMap},
             {"mucosa_version", std::string(version())},
             {"frames_registered", run.frames.size()},
             {"frames_converged", std::count_if(run.frames.begin(), run.frames.end(),
                                                [](const RegisteredFrame& f) { return f.r.converged; })}}},
           {"frames", json::array()}};
    frames::writeResponse(j, run.camera.response);
    // A deviation that is not a finite number (not computed, or an axis the
    // frame does not constrain at all) is written as null.
    auto deviations = [](const FrameRegistration& r, std::size_t first) {
        json a = json::array();
        for (std::size_t axis = first; axis < first + 3; ++axis)
            a.push_back(std::isfinite(r.poseSd[axis]) ? json(r.poseSd[axis]) : json(nullptr));
        return a;
    };
    for (const RegisteredFrame& f : run.frames) {
        json m = json::array();
        for (const auto& row : f.r.cameraToWorld) m.push_back(row);
        j["frames"].push_back(
            json{{"image", frames::relativePath(f.image, folder)},
                 {"intrinsics", k},
                 {"camera_to_world", m},
                 {"registration",
                  {{"similarity", f.r.similarity},
                   {"iterations", f.r.iterations},
                   {"renders", f.r.evaluations},
                   {"converged", f.r.converged},
                   {"map_disagreed", f.r.mapDisagreed},
                   {"map_pose_kept", f.r.mapPoseKept},
                   {"no_lumen", f.r.noLumen},
                   {"searched", f.r.searched},
                   {"depth_range", std::isfinite(f.r.depthRange) ? json(f.r.depthRange) : json()},
                   {"pose_sd", {{"position_mm", deviations(f.r, 0)}, {"rotation_deg", deviations(f.r, 3)}}},
                   {"seconds",
                    {{"render", f.r.renderSeconds},
                     {"similarity", f.r.similaritySeconds},
                     {"optimiser", f.r.optimiserSeconds}}}}}});
    }
    writeFileAtomic(path, j.dump(1) + "\n");
}

RegistrationRun readRegistration(const fs::path& path) {
    const std::string file = path.string();
    const frames::FrameSet set = frames::readFrames(path);  // the frames file's own checks
    const json j = detail::parseJsonFile(readTextFile(path), file);
    if (!j.contains("registration") || !j["registration"].is_object() || !j["registration"].contains("method") ||
        !j["registration"]["method"].is_string())
        throw InputError("field 'registration'", file, "is missing: not written by mucosa register");
    RegistrationRun run;
    const std::string method = j["registration"]["method"].get<std::string>();
    if (method != "pq" && method != "intensity")
        throw InputError("field 'registration.method'", file, "must be pq or intensity");
    run.method = method == "pq" ? RegistrationMethod::PqSpace : RegistrationMethod::Intensity;
    if (j["registration"].contains("mesh") && j["registration"]["mesh"].is_string())
        run.mesh = j["registration"]["mesh"].get<std::string>();
    if (j["registration"].contains("albedo_map") && j["registration"]["albedo_map"].is_boolean())
        run.albedoMap = j["registration"]["albedo_map"].get<bool>();
    run.camera.response = set.response;
    run.camera.lightOffset = set.lightOffset;
    if (!set.frames.empty()) run.camera.K = set.frames.front().K;
    for (std::size_t i = 0; i < set.frames.size(); ++i) {
        RegisteredFrame f;
        f.image = set.frames[i].image;
        f.r.cameraToWorld = set.frames[i].cameraToWorld;
        f.r.converged = !set.frames[i].flagged;
        const json& r = j["frames"][i].value("registration", json::object());
        if (r.is_object()) {
            if (r.contains("similarity") && r["similarity"].is_number()) f.r.similarity = r["similarity"].get<double>();
            if (r.contains("iterations") && r["iterations"].is_number_integer())
                f.r.iterations = r["iterations"].get<int>();
            if (r.contains("renders") && r["renders"].is_number_integer()) f.r.evaluations = r["renders"].get<int>();
            if (r.contains("map_disagreed") && r["map_disagreed"].is_boolean())
                f.r.mapDisagreed = r["map_disagreed"].get<bool>();
            if (r.contains("pose_sd") && r["pose_sd"].is_object()) {
                const char* keys[2] = {"position_mm", "rotation_deg"};
                for (std::size_t part = 0; part < 2; ++part) {
                    const json& a = r["pose_sd"].value(keys[part], json());
                    if (!a.is_array() || a.size() != 3) continue;
                    for (std::size_t k = 0; k < 3; ++k)
                        if (a[k].is_number()) f.r.poseSd[3 * part + k] = a[k].get<double>();
                }
            }
            if (r.contains("depth_range") && r["depth_range"].is_number())
                f.r.depthRange = r["depth_range"].get<double>();
            if (r.contains("no_lumen") && r["no_lumen"].is_boolean())
                f.r.noLumen = r["no_lumen"].get<bool>() && !f.r.converged;
            // The tracker resumes from a searched pose too (Tracker::update).
            if (r.contains("searched") && r["searched"].is_boolean()) f.r.searched = r["searched"].get<bool>();
            // The tracker resumes from it as it went on (Tracker::anchorOnMap).
            if (r.contains("map_pose_kept") && r["map_pose_kept"].is_boolean())
                f.r.mapPoseKept = r["map_pose_kept"].get<bool>() && !f.r.converged;
        }
        run.frames.push_back(std::move(f));
    }
    return run;
}

void checkInitialView(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& pose,
                      const frames::Vec3d& lightOffset, const std::string& meshFile, const std::string& poseFile) {
    if (!mesh.hasNormals()) throw InputError("mesh", meshFile, "has no normals");
    frames::Intrinsics k = K;
    const double s = 80.0 / K.width;
    k.width = 80;
    k.height = std::max(1, static_cast<int>(std::lround(K.height * s)));
    k.fx = K.fx * s;
    k.fy = K.fy * (static_cast<double>(k.height) / K.height);
    k.cx = (K.cx + 0.5) * s - 0.5;
    k.cy = (K.cy + 0.5) * (static_cast<double>(k.height) / K.height) - 0.5;
    k.k1 = k.k2 = 0;
    const ModelView v = renderModel(mesh, k, pose, lightOffset, 0, 1);
    double hits = 0, lit = 0, near = 0;  // pixel counts
    for (std::size_t i = 0; i < v.seen.size(); ++i) {
        const float z = v.depth.data()[i];
        if (!std::isfinite(z)) continue;
        ++hits;
        if (v.shading.data()[i] > 0) ++lit;
        if (z < 1.5f) ++near;
    }
    const double n = static_cast<double>(v.seen.size());
    if (hits < 0.1 * n)
        throw InputError("initial pose", poseFile,
                         fmt::format("sees the mesh in {:.0f} % of the view: it is outside the airway or looks out "
                                     "of an open end of {}",
                                     100.0 * hits / n, meshFile));
    if (lit < 0.5 * hits) {
        // Normals facing out of the lumen, or a camera outside it? The mesh's
        // signed volume says which way its surface faces.
        const mesh::MeshReport rep = mesh::analyze(mesh);
        if (rep.signedVolume > 0)
            throw InputError("mesh", meshFile,
                             "its normals face out of the lumen (positive signed volume): registration needs them "
                             "facing the camera inside; turn them with `mucosa mesh IN -o OUT --orient lumen`");
        throw InputError("initial pose", poseFile,
                         fmt::format("sees the back of the airway wall in {:.0f} % of the view: it is outside the "
                                     "airway of {}",
                                     100.0 * (hits - lit) / hits, meshFile));
    }
    if (near > 0.6 * hits)
        throw InputError("initial pose", poseFile,
                         fmt::format("faces a wall: {:.0f} % of the view is closer than 1.5 mm", 100.0 * near / hits));
}

namespace {

// (p, q) as a colour: the normal (p, q, -1)/N mapped to RGB, grey where masked.
image::Image8 pqImage(const PqField& f) {
    image::Image8 img(f.width, f.height, 3);
    for (std::size_t i = 0; i < f.weight.size(); ++i) {
        std::array<std::uint8_t, 3> c{40, 40, 40};
        if (f.weight[i] > 0) {
            const auto& n = f.normal[i];
            c = {static_cast<std::uint8_t>(std::lround(127.5 * (1 + n[0]))),
                 static_cast<std::uint8_t>(std::lround(127.5 * (1 + n[1]))),
                 static_cast<std::uint8_t>(std::lround(255 * std::clamp(-n[2], 0.f, 1.f)))};
        }
        for (int k = 0; k < 3; ++k) img.data()[3 * i + k] = c[k];
    }
    return img;
}

image::Image8 upscale(const image::Image8& a, int factor) {
    image::Image8 o(a.width() * factor, a.height() * factor, a.channels());
    for (int y = 0; y < o.height(); ++y)
        for (int x = 0; x < o.width(); ++x)
            for (int c = 0; c < a.channels(); ++c) o.at(x, y, c) = a.at(x / factor, y / factor, c);
    return o;
}

std::string svgTrace(const RegistrationRun& run) {
    const int W = 720, H = 240, L = 50, R = 10, T = 15, B = 35;
    const std::size_t n = run.frames.size();
    double lo = 1.0;
    for (const auto& f : run.frames) lo = std::min(lo, f.r.similarity);
    lo = std::floor(std::max(-1.0, lo) * 10) / 10;
    auto X = [&](double i) { return L + (n > 1 ? i / static_cast<double>(n - 1) : 0.5) * (W - L - R); };
    auto Y = [&](double s) { return T + (1.0 - (s - lo) / (1.0 - lo + 1e-12)) * (H - T - B); };
    std::string svg =
        fmt::format(R"(<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" font-size="11">)", W, H);
    svg += fmt::format(R"(<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#888"/>)", L, T, W - L - R,
                       H - T - B);
    for (int t = 0; t <= 4; ++t) {
        const double s = lo + (1.0 - lo) * t / 4.0;
        svg += fmt::format(R"(<text x="{}" y="{:.1f}" text-anchor="end">{:.2f}</text>)", L - 4, Y(s) + 4, s);
    }
    svg += fmt::format(R"(<text x="{}" y="{}" text-anchor="middle">frame</text>)", (W + L) / 2, H - 5);
    std::string pts;
    for (std::size_t i = 0; i < n; ++i)
        pts += fmt::format("{:.1f},{:.1f} ", X(double(i)), Y(run.frames[i].r.similarity));
    svg += R"(<polyline fill="none" stroke="#1f77b4" stroke-width="1.5" points=")" + pts + "\"/>";
    for (std::size_t i = 0; i < n; ++i)
        if (!run.frames[i].r.converged)
            svg += fmt::format(
                R"(<circle cx="{:.1f}" cy="{:.1f}" r="3" fill="#d62728"><title>frame {} not converged{}</title></circle>)",
                X(double(i)), Y(run.frames[i].r.similarity), i,
                run.frames[i].r.noLumen
                    ? (run.frames[i].r.searched ? " (no lumen in view; moved by the search)" : " (no lumen in view)")
                : run.frames[i].r.mapDisagreed ? " (the albedo map's pose disagrees)"
                                               : "");
    return svg + "</svg>";
}

}  // namespace

void writeRegistrationReport(const fs::path& dir, const RegistrationRun& run, const mesh::Mesh& mesh,
                             const RegisterOptions& options, int samples) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw IoError("report folder", dir.string(), ec.message());
    std::string rows;
    std::set<std::string> written;  // the sampled frames' image stems
    const std::size_t n = run.frames.size();
    const int count = static_cast<int>(std::min<std::size_t>(n, static_cast<std::size_t>(std::max(0, samples))));
    RegisterOptions o = options;
    o.method = RegistrationMethod::PqSpace;  // the pq fields are shown for either method
    // The fields at the registration's finest working width, as it saw them.
    o.levels = {std::min(options.levels.empty() ? 80 : options.levels.back(), run.camera.K.width)};
    for (int s = 0; s < count; ++s) {
        const std::size_t i = count > 1 ? s * (n - 1) / static_cast<std::size_t>(count - 1) : 0;
        const RegisteredFrame& f = run.frames[i];
        frames::Frame fr;
        fr.image = f.image;
        fr.K = run.camera.K;
        image::Image8 sat;
        const image::ImageF linear = fit::loadFrameImage(fr, run.camera.response, &sat, o.saturation);
        const VideoFrame vf = prepareFrame(linear, &sat, run.camera.K, o);
        const VideoFrame::Level& L = vf.levels.back();
        const ModelView mv = renderModel(mesh, L.K, f.r.cameraToWorld, run.camera.lightOffset, 0, 2, run.camera.lamp,
                                         options.brdf ? &*options.brdf : nullptr);
        const PqField model = pqFromModel(mv, L.K, L.pqOptions, &L.pq.usable);
        // The frame (display-referred) with the model's silhouette: occluding
        // contours and the edge of what it sees, where depth jumps.
        image::Image8 over(L.K.width, L.K.height, 3);
        const double gamma = 1.0 / 2.2;
        // Shown scaled to the frame's 99th percentile (the lamp leaves most
        // of a frame dark in linear terms).
        std::vector<float> lum(L.luminance.data(), L.luminance.data() + L.luminance.size());
        std::nth_element(lum.begin(), lum.begin() + static_cast<std::ptrdiff_t>(lum.size() * 99 / 100), lum.end());
        const double white = std::max(1e-6, double(lum[lum.size() * 99 / 100]));
        for (int y = 0; y < L.K.height; ++y)
            for (int x = 0; x < L.K.width; ++x) {
                const std::size_t k = static_cast<std::size_t>(y) * L.K.width + x;
                const auto v = static_cast<std::uint8_t>(
                    std::lround(255 * std::pow(std::clamp(L.luminance.data()[k] / white, 0.0, 1.0), gamma)));
                std::array<std::uint8_t, 3> c{v, v, v};
                const float z = mv.depth.data()[k];
                bool edge = false;
                for (int d = 0; d < 4 && !edge; ++d) {
                    const int xx = x + (d == 0) - (d == 1), yy = y + (d == 2) - (d == 3);
                    if (xx < 0 || yy < 0 || xx >= L.K.width || yy >= L.K.height) continue;
                    const float z2 = mv.depth.data()[static_cast<std::size_t>(yy) * L.K.width + xx];
                    edge = std::isfinite(z) != std::isfinite(z2) ||
                           (std::isfinite(z) && std::abs(z - z2) > 0.15f * std::min(z, z2));
                }
                if (edge) c = {60, 255, 80};
                for (int ch = 0; ch < 3; ++ch) over.at(x, y, ch) = c[ch];
            }
        const int up = std::max(1, 320 / L.K.width);
        const std::string stem = fmt::format("frame{:05d}", i);
        written.insert(stem);
        image::writePng(dir / (stem + "_overlay.png"), upscale(over, up));
        image::writePng(dir / (stem + "_pq_video.png"), upscale(pqImage(L.pq), up));
        image::writePng(dir / (stem + "_pq_model.png"), upscale(pqImage(model), up));
        // The pose's standard deviations (camera axes; "-": none, or undetermined).
        auto sd = [&](std::size_t k, int digits) {
            return std::isfinite(f.r.poseSd[k]) ? fmt::format("{:.{}f}", f.r.poseSd[k], digits) : std::string("-");
        };
        rows += fmt::format(
            "<tr><td>{}<br>{}<br>similarity {:.3f}<br>{}<br>sd along x, y, z: {}, {}, {} mm; about x, y, z (the roll): "
            "{}, {}, {}&deg;</td>"
            "<td><img src=\"{}_overlay.png\"></td>"
            "<td><img src=\"{}_pq_video.png\"></td><td><img src=\"{}_pq_model.png\"></td></tr>\n",
            i, escapeXml(f.image.filename().string()), f.r.similarity,
            f.r.converged ? "converged"
            : f.r.noLumen
                ? (f.r.searched ? "<b>NOT converged</b> (no lumen in view; moved by the search around the track)"
                                : "<b>NOT converged</b> (no lumen in view)")
            : f.r.mapDisagreed ? "<b>NOT converged</b> (the albedo map's pose disagrees)"
                               : "<b>NOT converged</b>",
            sd(0, 2), sd(1, 2), sd(2, 2), sd(3, 1), sd(4, 1), sd(5, 1), stem, stem, stem);
    }
    const std::size_t converged = static_cast<std::size_t>(
        std::count_if(run.frames.begin(), run.frames.end(), [](const RegisteredFrame& f) { return f.r.converged; }));
    const std::string html = fmt::format(
        R"(<!doctype html><html><head><meta charset="utf-8"><title>mucosa register</title>
<style>body{{font-family:sans-serif;margin:2em}} td{{vertical-align:top;padding:4px}} img{{image-rendering:pixelated}}</style></head>
<body><h1>Registration: {} frames, method {}</h1>
<p>Mesh {}; {} of {} frames converged. Similarity: {} (pq: confidence-weighted mean cosine of the normals; intensity: normalised cross-correlation).</p>
{}
<h2>Sampled frames</h2>
<p>Left: the frame with the registered model's silhouette (green: where the model's depth jumps). Middle and right: the video's and the model's (p, q) fields as normals (R = x, G = y, B = facing the camera; grey: no estimate).</p>
<table>{}</table>
<p>Mucosa {}</p></body></html>
)",
        n, methodName(run.method), escapeXml(run.mesh), converged, n,
        run.method == RegistrationMethod::PqSpace ? "pq" : "NCC", svgTrace(run), rows, version());
    writeFileAtomic(dir / "index.html", html);
    // Images an earlier report of another run left (other frames sampled)
    // would sit beside this one's: removed. Only files named as the report
    // names its images; nothing else in the folder is touched.
    static const std::regex own(R"(^(frame[0-9]{5})_(overlay|pq_video|pq_model)\.png$)");
    std::vector<fs::path> stale;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
        std::smatch m;
        const std::string name = e.path().filename().string();
        if (e.is_regular_file(ec) && std::regex_match(name, m, own) && !written.count(m[1].str()))
            stale.push_back(e.path());
    }
    for (const fs::path& f : stale) fs::remove(f, ec);
}

}  // namespace mucosa::registration
