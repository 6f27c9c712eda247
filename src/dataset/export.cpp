// The exporters: see include/mucosa/dataset/export.hpp.
//
// Where each format's conventions are documented (checked against the
// formats' own documentation and source, not guessed):
//  - COLMAP, doc/format.rst ("images.txt"): a pose is world-to-camera, a
//    Hamilton quaternion QW QX QY QZ and a translation TX TY TZ; camera axes
//    x right, y down, z forward (OpenCV's); two lines per image, the second
//    the image's 2-D points. doc/database.rst ("Keypoints and Descriptors"):
//    the top-left image corner is (0, 0) and the top-left pixel's centre
//    (0.5, 0.5). src/colmap/sensor/models.h: PINHOLE fx fy cx cy; OPENCV
//    fx fy cx cy k1 k2 p1 p2 (OpenCVCameraModel::Distortion, OpenCV's radial
//    and tangential terms); OPENCV_FISHEYE fx fy cx cy k1 k2 k3 k4.
//    src/colmap/scene/reconstruction_io.cc (ReadImagesText): fields are split
//    at spaces, so a NAME cannot hold one, and the line after an image line
//    is always read as its 2-D points. doc/faq.rst ("Reconstruct sparse/dense
//    model from known camera poses"): such a model has an empty points3D.txt
//    and an empty line after each image.
//  - TUM RGB-D benchmark, "File Formats" page: `timestamp tx ty tz qx qy qz qw`,
//    the position and orientation of the camera's optical centre in the world
//    (camera-to-world); its evaluate_rpe.py (transform44) reads the quaternion
//    as Hamilton with the scalar last, its evaluate_ate.py reports metres and
//    its depth images are 5000 per metre: the unit is the metre. Its camera
//    frame (generate_pointcloud.py: X = (u - cx) Z / fx, Y = (v - cy) Z / fy)
//    is OpenCV's.
//  - nerfstudio, docs/quickstart/data_conventions.md: OpenGL/Blender camera
//    axes (x right, y up, z back; OpenCV's with y and z flipped),
//    transform_matrix camera-to-world, intrinsics at the top of the file when
//    shared. nerfstudio/data/dataparsers/nerfstudio_dataparser.py: fl_x, fl_y,
//    cx, cy, w, h and k1..k4, p1, p2 global or per frame (a key at the top
//    wins), camera_model global, file_path relative to transforms.json's
//    folder; "applied_scale" already means something (it rescales a
//    ply_file_path point cloud), so the scale is recorded under "mucosa".
//    nerfstudio/cameras/cameras.py: get_image_coords puts pixel (row, col) at
//    (col + 0.5, row + 0.5) (pixel_offset 0.5) and _generate_rays_from_coords
//    takes ((x - cx) / fx, (y - cy) / fy), then flips y and sets z = -1: cx is
//    in COLMAP's pixel convention. nerfstudio/cameras/camera_utils.py: the
//    distortion [k1 k2 k3 k4 p1 p2] is 1 + k1 r^2 + k2 r^4 + k3 r^6 + k4 r^8
//    with OpenCV's tangential terms.
#include <mucosa/dataset/export.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <system_error>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/version.hpp>

namespace mucosa::dataset {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

// COLMAP's and nerfstudio's pixel coordinates are Mucosa's plus half a pixel:
// their top-left pixel's centre is (0.5, 0.5), Mucosa's (0, 0).
constexpr double kPixelCentreShift = 0.5;
// TUM timestamps have 6 decimals; frames stay distinct up to 100000 fps.
constexpr double kMaxFps = 100000;

struct Context {
    std::string file;            // the frames file: named in errors and recorded in the outputs
    const Lens* lens = nullptr;  // the frames file's lens (ExportOptions::lens)
};

std::string frameField(std::size_t i, const char* key) {
    return fmt::format("field 'frames[{}].{}'", i, key);
}

// Shortest text that reads back as the same double; no "-0".
std::string num(double v) {
    return fmt::format("{}", v == 0 ? 0.0 : v);
}

void checkPose(const frames::Mat4& m, std::size_t i, const Context& c) {
    const std::string field = frameField(i, "camera_to_world");
    for (const auto& row : m)
        for (double v : row)
            if (!std::isfinite(v)) throw InputError(field, c.file, "must hold finite numbers");
    if (m[3][0] != 0 || m[3][1] != 0 || m[3][2] != 0 || m[3][3] != 1)
        throw InputError(field, c.file, "is not a rigid transform: its last row must be 0 0 0 1");
    const frames::Rigidity rigid = frames::rigidity(m);
    if (rigid.orthonormality > frames::kRigidTolerance)
        throw InputError(field, c.file,
                         fmt::format("is not a rigid transform: its rotation is not orthonormal (off by {:.3g})",
                                     rigid.orthonormality));
    if (rigid.determinant < 0)
        throw InputError(field, c.file, "is not a rigid transform: its rotation is a reflection (det -1)");
}

void checkIntrinsics(const frames::Intrinsics& K, std::size_t i, const Context& c) {
    const std::string field = frameField(i, "intrinsics");
    if (K.width < 1 || K.height < 1 || K.width > 65536 || K.height > 65536)
        throw InputError(field, c.file, "width and height must be whole numbers in 1..65536");
    if (!(K.fx > 0) || !(K.fy > 0) || !std::isfinite(K.fx) || !std::isfinite(K.fy))
        throw InputError(field, c.file, "focal lengths must be positive and finite");
    for (double v : {K.cx, K.cy, K.k1, K.k2})
        if (!std::isfinite(v)) throw InputError(field, c.file, "cx, cy, k1 and k2 must be finite");
}

bool sameIntrinsics(const frames::Intrinsics& a, const frames::Intrinsics& b) noexcept {
    return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy &&
           a.k1 == b.k1 && a.k2 == b.k2;
}

// A frame's pose in the output's units: the rotation of its unit quaternion
// (so every format holds exactly the same rotation) and its camera centre.
struct Pose {
    Quaternion q;
    frames::Mat4 R;  // camera-to-world rotation, OpenCV axes
    frames::Vec3d C;
};

Pose poseOf(const frames::Frame& f, double scale) {
    Pose p;
    p.q = quaternionFromRotation(f.cameraToWorld);
    p.R = rotationFromQuaternion(p.q);
    for (int r = 0; r < 3; ++r) p.C[r] = f.cameraToWorld[r][3] * scale;
    return p;
}

// `target` relative to `folder` ('/' separators), lexically, or absolute
// when it cannot be (another root).
std::string relativeName(const fs::path& target, const fs::path& folder) {
    std::error_code ec;
    const fs::path t = fs::absolute(target, ec).lexically_normal();
    const fs::path base = fs::absolute(folder.empty() ? fs::path(".") : folder, ec).lexically_normal();
    const fs::path rel = t.lexically_relative(base);
    return rel.empty() ? t.generic_string() : rel.generic_string();
}

// The frames to export (not flagged), checked.
std::vector<std::size_t> exportedFrames(const frames::FrameSet& set, const Context& c, std::size_t& skipped) {
    if (set.frames.empty()) throw InputError("field 'frames'", c.file, "is empty: there is nothing to export");
    std::vector<std::size_t> keep;
    skipped = 0;
    for (std::size_t i = 0; i < set.frames.size(); ++i) {
        checkPose(set.frames[i].cameraToWorld, i, c);
        checkIntrinsics(set.frames[i].K, i, c);
        if (set.frames[i].flagged)
            ++skipped;
        else
            keep.push_back(i);
    }
    if (keep.empty())
        throw InputError("field 'frames'", c.file,
                         "every frame is flagged as not converged by mucosa register: there is nothing to export");
    return keep;
}

std::string absoluteName(const fs::path& p) {
    std::error_code ec;
    return fs::absolute(p.empty() ? fs::path(".") : p, ec).lexically_normal().generic_string();
}

std::string header(const char* title, const Context& c) {
    return fmt::format("# {}, written by Mucosa {} from {}\n", title, version(),
                       c.file.empty() ? std::string("a frame set") : c.file);
}

// --- TUM RGB-D -------------------------------------------------------------

void buildTum(const frames::FrameSet& set, const std::vector<std::size_t>& keep, const ExportOptions& o,
              const Context& c, Export& e, const fs::path& out) {
    std::string text = header("TUM RGB-D trajectory", c);
    text +=
        "# timestamp tx ty tz qx qy qz qw: camera-to-world, the camera's optical centre and orientation in the world\n";
    text += fmt::format("# units: {} ({} per mm of the frames file); frame i at i / {} s\n", unitName(e.scale),
                        num(e.scale), num(o.fps));
    text += "# camera axes: x right, y down, z forward (OpenCV); unit quaternion, Hamilton, scalar last\n";
    for (std::size_t i : keep) {
        const Pose p = poseOf(set.frames[i], e.scale);
        text += fmt::format("{:.6f} {} {} {} {} {} {} {}\n", static_cast<double>(i) / o.fps, num(p.C[0]), num(p.C[1]),
                            num(p.C[2]), num(p.q.x), num(p.q.y), num(p.q.z), num(p.q.w));
    }
    e.files.push_back({out, std::move(text)});
}

// --- COLMAP ----------------------------------------------------------------

struct ColmapCamera {
    const char* model;
    std::vector<double> params;
};

// One case per lens. A fisheye lens: OPENCV_FISHEYE {fx, fy, cx, cy, k1, k2, k3, k4}.
ColmapCamera colmapCamera(const frames::Intrinsics& K, const Lens* lens) {
    const double cx = K.cx + kPixelCentreShift, cy = K.cy + kPixelCentreShift;
    switch (lensOf(K, lens)) {
        case ExportLens::Pinhole:
            return {"PINHOLE", {K.fx, K.fy, cx, cy}};
        case ExportLens::BrownRadial:
            return {"OPENCV", {K.fx, K.fy, cx, cy, K.k1, K.k2, 0.0, 0.0}};
        case ExportLens::Fisheye:
            return {"OPENCV_FISHEYE", {K.fx, K.fy, cx, cy, lens->k1, lens->k2, lens->k3, lens->k4}};
    }
    MUCOSA_CHECK(false, "unknown lens");
    return {};
}

void buildColmap(const frames::FrameSet& set, const std::vector<std::size_t>& keep, const ExportOptions& o,
                 const Context& c, Export& e, const fs::path& out) {
    std::vector<const frames::Intrinsics*> cameras;
    std::vector<std::size_t> cameraOf(set.frames.size(), 0);
    for (std::size_t i : keep) {
        const frames::Intrinsics& K = set.frames[i].K;
        auto it = std::find_if(cameras.begin(), cameras.end(), [&](const auto* k) { return sameIntrinsics(*k, K); });
        cameraOf[i] = static_cast<std::size_t>(it - cameras.begin()) + 1;
        if (it == cameras.end()) cameras.push_back(&K);
    }
    e.cameras = cameras.size();

    std::string cams = header("COLMAP text model", c);
    cams += "# CAMERA_ID MODEL WIDTH HEIGHT PARAMS...: pixels, the top-left pixel's centre at (0.5, 0.5)\n";
    cams += fmt::format("# {} camera{}\n", cameras.size(), cameras.size() == 1 ? "" : "s");
    for (std::size_t k = 0; k < cameras.size(); ++k) {
        const ColmapCamera cam = colmapCamera(*cameras[k], c.lens);
        cams += fmt::format("{} {} {} {}", k + 1, cam.model, cameras[k]->width, cameras[k]->height);
        for (double v : cam.params) cams += fmt::format(" {}", num(v));
        cams += "\n";
    }

    std::string images = header("COLMAP text model", c);
    images += "# IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, then the image's 2-D points (none)\n";
    images += fmt::format("# world-to-camera, camera axes x right, y down, z forward; units: {} ({} per mm)\n",
                          unitName(e.scale), num(e.scale));
    images += fmt::format("# NAME relative to {} (COLMAP's --image_path)\n", absoluteName(o.imageRoot));
    std::size_t id = 0;
    for (std::size_t i : keep) {
        const std::string name = relativeName(set.frames[i].image, o.imageRoot);
        if (name.find_first_of(" \t\r\n") != std::string::npos)
            throw InputError(
                frameField(i, "image"), c.file,
                fmt::format("'{}' holds a space, and COLMAP's images.txt splits its fields at spaces", name));
        const Pose p = poseOf(set.frames[i], e.scale);
        // World-to-camera: the inverse rotation (the conjugate quaternion) and
        // t = -R^T C.
        double t[3];
        for (int r = 0; r < 3; ++r) t[r] = -(p.R[0][r] * p.C[0] + p.R[1][r] * p.C[1] + p.R[2][r] * p.C[2]);
        images += fmt::format("{} {} {} {} {} {} {} {} {} {}\n\n", ++id, num(p.q.w), num(-p.q.x), num(-p.q.y),
                              num(-p.q.z), num(t[0]), num(t[1]), num(t[2]), cameraOf[i], name);
    }

    std::string points = header("COLMAP text model", c);
    points += "# no 3-D points: the poses and intrinsics are known, nothing was triangulated\n";

    e.files.push_back({out / "cameras.txt", std::move(cams)});
    e.files.push_back({out / "images.txt", std::move(images)});
    e.files.push_back({out / "points3D.txt", std::move(points)});
}

// --- nerfstudio ------------------------------------------------------------

// One case per lens. A fisheye lens: "OPENCV_FISHEYE" with k1..k4 (nerfstudio's
// CAMERA_MODEL_TO_TYPE), no p1, p2.
const char* nerfstudioModel(const frames::Intrinsics& K, const Lens* lens) {
    switch (lensOf(K, lens)) {
        case ExportLens::Pinhole:
        case ExportLens::BrownRadial:
            return "OPENCV";  // a pinhole is OPENCV with zero coefficients
        case ExportLens::Fisheye:
            return "OPENCV_FISHEYE";
    }
    MUCOSA_CHECK(false, "unknown lens");
    return "";
}

ojson nerfstudioIntrinsics(const frames::Intrinsics& K, const Lens* lens) {
    ojson j{{"fl_x", K.fx}, {"fl_y", K.fy}, {"cx", K.cx + kPixelCentreShift}, {"cy", K.cy + kPixelCentreShift},
            {"w", K.width}, {"h", K.height}};
    switch (lensOf(K, lens)) {
        case ExportLens::Fisheye:
            j["k1"] = lens->k1;
            j["k2"] = lens->k2;
            j["k3"] = lens->k3;
            j["k4"] = lens->k4;
            break;
        case ExportLens::Pinhole:
        case ExportLens::BrownRadial:
            j["k1"] = K.k1;
            j["k2"] = K.k2;
            j["k3"] = 0.0;
            j["k4"] = 0.0;
            j["p1"] = 0.0;
            j["p2"] = 0.0;
            break;
    }
    return j;
}

void buildNerfstudio(const frames::FrameSet& set, const std::vector<std::size_t>& keep, const Context& c, Export& e,
                     const fs::path& out) {
    std::error_code ec;
    const fs::path file = fs::is_directory(out, ec) ? out / "transforms.json" : out;
    const char* model = nerfstudioModel(set.frames[keep.front()].K, c.lens);
    bool shared = true;
    std::vector<const frames::Intrinsics*> distinct;
    for (std::size_t i : keep) {
        const frames::Intrinsics& K = set.frames[i].K;
        if (std::string_view(nerfstudioModel(K, c.lens)) != model)
            throw InputError(frameField(i, "intrinsics"), c.file,
                             "nerfstudio has one camera_model per file, and this frame's lens needs another");
        shared = shared && sameIntrinsics(K, set.frames[keep.front()].K);
        if (std::none_of(distinct.begin(), distinct.end(), [&](const auto* k) { return sameIntrinsics(*k, K); }))
            distinct.push_back(&K);
    }
    e.cameras = distinct.size();

    ojson j = ojson::object();
    j["camera_model"] = model;
    if (shared) {
        const ojson K = nerfstudioIntrinsics(set.frames[keep.front()].K, c.lens);
        for (const auto& [key, value] : K.items()) j[key] = value;
    }
    j["frames"] = ojson::array();
    for (std::size_t i : keep) {
        const Pose p = poseOf(set.frames[i], e.scale);
        // OpenCV axes to OpenGL's: the camera's y and z columns negated.
        ojson m = ojson::array();
        for (int r = 0; r < 3; ++r) m.push_back({p.R[r][0] + 0.0, -p.R[r][1] + 0.0, -p.R[r][2] + 0.0, p.C[r] + 0.0});
        m.push_back({0.0, 0.0, 0.0, 1.0});
        ojson f{{"file_path", relativeName(set.frames[i].image, file.parent_path())}};
        if (!shared) {
            const ojson K = nerfstudioIntrinsics(set.frames[i].K, c.lens);
            for (const auto& [key, value] : K.items()) f[key] = value;
        }
        f["transform_matrix"] = std::move(m);
        j["frames"].push_back(std::move(f));
    }
    j["mucosa"] = {{"version", std::string(version())},
                   {"source", c.file},
                   {"units", unitName(e.scale)},
                   {"scale_per_mm", e.scale},
                   {"camera_axes", "OpenGL: x right, y up, z backwards (camera looks along -z)"},
                   {"pixel_centres", "top-left pixel's centre at (0.5, 0.5)"}};
    e.files.push_back({file, j.dump(2) + "\n"});
}

}  // namespace

const char* exportFormatName(ExportFormat format) noexcept {
    switch (format) {
        case ExportFormat::Tum:
            return "tum";
        case ExportFormat::Colmap:
            return "colmap";
        case ExportFormat::Nerfstudio:
            return "nerfstudio";
    }
    return "";
}

ExportFormat parseExportFormat(std::string_view name, const std::string& field, const std::string& file) {
    for (ExportFormat f : {ExportFormat::Tum, ExportFormat::Colmap, ExportFormat::Nerfstudio})
        if (name == exportFormatName(f)) return f;
    throw InputError(field, file, fmt::format("unknown format '{}' (known: tum, colmap, nerfstudio)", name));
}

double defaultScale(ExportFormat format) noexcept {
    return format == ExportFormat::Tum ? 0.001 : 1.0;
}

std::string unitName(double scale) {
    if (scale == 1.0) return "mm";
    if (scale == 0.1) return "cm";
    if (scale == 0.001) return "m";
    return fmt::format("{} x mm", num(scale));
}

ExportLens lensOf(const frames::Intrinsics& K, const Lens* lens) noexcept {
    if (lens && lens->model == LensModel::Fisheye) return ExportLens::Fisheye;
    return K.k1 == 0 && K.k2 == 0 ? ExportLens::Pinhole : ExportLens::BrownRadial;
}

Quaternion quaternionFromRotation(const frames::Mat4& m) noexcept {
    // Shepperd 1978 ("Quaternion from rotation matrix", J. Guidance and
    // Control 1(3)): divide by the largest of 4w^2, 4x^2, 4y^2, 4z^2, so no
    // branch loses precision near a half turn.
    const double t = m[0][0] + m[1][1] + m[2][2];
    Quaternion q;
    if (t >= m[0][0] && t >= m[1][1] && t >= m[2][2]) {
        const double s = 2.0 * std::sqrt(1.0 + t);  // 4w
        q = {0.25 * s, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s};
    } else if (m[0][0] >= m[1][1] && m[0][0] >= m[2][2]) {
        const double s = 2.0 * std::sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]);  // 4x
        q = {(m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s};
    } else if (m[1][1] >= m[2][2]) {
        const double s = 2.0 * std::sqrt(1.0 - m[0][0] + m[1][1] - m[2][2]);  // 4y
        q = {(m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s};
    } else {
        const double s = 2.0 * std::sqrt(1.0 - m[0][0] - m[1][1] + m[2][2]);  // 4z
        q = {(m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s};
    }
    const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    const double sign = q.w < 0 ? -1.0 : 1.0;  // q and -q are the same rotation: w >= 0
    return {sign * q.w / n, sign * q.x / n, sign * q.y / n, sign * q.z / n};
}

frames::Mat4 rotationFromQuaternion(const Quaternion& q) noexcept {
    const double w = q.w, x = q.x, y = q.y, z = q.z;
    frames::Mat4 m{};
    m[0] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), 0};
    m[1] = {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), 0};
    m[2] = {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), 0};
    m[3] = {0, 0, 0, 1};
    return m;
}

Export buildExport(const frames::FrameSet& set, ExportFormat format, const fs::path& out, const ExportOptions& o) {
    const Context c{o.source.string(), o.lens ? &*o.lens : nullptr};
    if (o.lens && o.lens->model == LensModel::Omnidirectional && format != ExportFormat::Tum)
        throw InputError("field 'lens'", c.file,
                         fmt::format("is omnidirectional (Scaramuzza's model), which {} cannot describe; export "
                                     "the trajectory (--format tum), or render the dataset through a fisheye",
                                     exportFormatName(format)));
    if (!(o.fps > 0) || !(o.fps <= kMaxFps))
        throw InputError("fps", "", fmt::format("must be a number of frames per second in (0, {}]", num(kMaxFps)));
    Export e;
    e.format = format;
    e.scale = o.scale.value_or(defaultScale(format));
    if (!(e.scale > 0) || !std::isfinite(e.scale))
        throw InputError("scale", "", "must be a positive number of output units per mm (0.001: metres)");
    const std::vector<std::size_t> keep = exportedFrames(set, c, e.skipped);
    e.frames = keep.size();
    std::error_code ec;
    switch (format) {
        case ExportFormat::Tum:
            if (fs::is_directory(out, ec)) throw IoError("output file", out.string(), "is a folder");
            e.cameras = 0;
            buildTum(set, keep, o, c, e, out);
            break;
        case ExportFormat::Colmap:
            if (fs::exists(out, ec) && !fs::is_directory(out, ec))
                throw IoError("output folder", out.string(), "exists and is not a directory");
            e.folder = out;
            buildColmap(set, keep, o, c, e, out);
            break;
        case ExportFormat::Nerfstudio:
            buildNerfstudio(set, keep, c, e, out);
            break;
    }
    return e;
}

void writeExport(const Export& e) {
    bool created = false;
    std::error_code ec;
    if (!e.folder.empty() && !fs::is_directory(e.folder, ec)) {
        if (!fs::create_directory(e.folder, ec) && ec)
            throw IoError("output folder", e.folder.string(), "cannot be created: " + ec.message());
        created = true;
    }
    try {
        std::vector<std::unique_ptr<AtomicFile>> files;
        for (const ExportFile& f : e.files) {
            files.push_back(std::make_unique<AtomicFile>(f.path));
            files.back()->write(f.text);
        }
        for (auto& f : files) f->commit();
    } catch (...) {
        if (created) fs::remove(e.folder, ec);  // only if still empty
        throw;
    }
}

Export exportFrames(const frames::FrameSet& set, ExportFormat format, const fs::path& out, const ExportOptions& o) {
    Export e = buildExport(set, format, out, o);
    writeExport(e);
    return e;
}

}  // namespace mucosa::dataset
