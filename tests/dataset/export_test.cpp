// The exporters (include/mucosa/dataset/export.hpp). Each exported file is
// read back here with its format's own documented convention, implemented in
// this file and not shared with export.cpp:
//  - COLMAP (doc/format.rst, src/colmap/sensor/models.h): world-to-camera
//    Hamilton quaternion and translation, OpenCV camera axes, PINHOLE or OPENCV
//    intrinsics, the top-left pixel's centre at (0.5, 0.5);
//  - TUM RGB-D: camera-to-world position and quaternion (scalar last), metres;
//  - nerfstudio (cameras.py, camera_utils.py): camera-to-world in OpenGL axes,
//    rays through ((x - cx) / fx, -(y - cy) / fy, -1) with pixel centres at +0.5.
// Known 3-D points projected through each must land where Mucosa's own
// camera (frames::project) puts them, to 1e-6 px.
#include <mucosa/dataset/export.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/frames/frames.hpp>

#include "test_support.hpp"

namespace mucosa::dataset {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test::TempDir;
using Vec3 = std::array<double, 3>;
using Mat3 = std::array<std::array<double, 3>, 3>;

constexpr double kPixelTolerance = 1e-6;

// --- the scene --------------------------------------------------------------

// Rodrigues: rotation by `angle` about `axis`.
Mat3 axisAngle(Vec3 axis, double angle) {
    const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    for (double& a : axis) a /= n;
    const double c = std::cos(angle), s = std::sin(angle), t = 1 - c;
    const double x = axis[0], y = axis[1], z = axis[2];
    return {{{t * x * x + c, t * x * y - s * z, t * x * z + s * y},
             {t * x * y + s * z, t * y * y + c, t * y * z - s * x},
             {t * x * z - s * y, t * y * z + s * x, t * z * z + c}}};
}

frames::Mat4 pose(const Mat3& R, const Vec3& C) {
    frames::Mat4 m{};
    for (int r = 0; r < 3; ++r) m[r] = {R[r][0], R[r][1], R[r][2], C[r]};
    m[3] = {0, 0, 0, 1};
    return m;
}

frames::Intrinsics pinhole() {
    frames::Intrinsics K;
    K.width = 320;
    K.height = 240;
    K.fx = 300;
    K.fy = 310;
    K.cx = 159.5;
    K.cy = 119.5;
    return K;
}

frames::Intrinsics radial() {
    frames::Intrinsics K;
    K.width = 640;
    K.height = 480;
    K.fx = 500;
    K.fy = 505;
    K.cx = 321.25;
    K.cy = 238.75;
    K.k1 = -0.21;
    K.k2 = 0.045;
    return K;
}

// Rotations that reach every branch of a matrix-to-quaternion conversion
// (half turns about x, y, z have trace -1) and random ones; the two lenses
// alternate.
frames::FrameSet scene(const fs::path& imageDir, bool twoLenses = true) {
    std::vector<Mat3> rotations = {axisAngle({1, 0, 0}, 0),          axisAngle({1, 0, 0}, M_PI),
                                   axisAngle({0, 1, 0}, M_PI),       axisAngle({0, 0, 1}, M_PI),
                                   axisAngle({1, 2, 3}, 2.5),        axisAngle({-1, 0.2, 0.1}, 3.1),
                                   axisAngle({0.3, -0.9, 0.2}, 0.7), axisAngle({0.1, 0.1, -1}, -2.9)};
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int i = 0; i < 8; ++i) rotations.push_back(axisAngle({u(rng), u(rng), u(rng)}, 3.14 * u(rng)));
    frames::FrameSet set;
    for (std::size_t i = 0; i < rotations.size(); ++i) {
        frames::Frame f;
        f.image = imageDir / ("frame_" + std::to_string(i) + ".png");
        f.K = twoLenses && i % 2 == 1 ? radial() : pinhole();
        f.cameraToWorld = pose(rotations[i], {100 * u(rng), 100 * u(rng), 100 * u(rng)});
        set.frames.push_back(f);
    }
    return set;
}

// Points in front of a frame's camera, in the world (mm), spread over its
// field of view.
std::vector<Vec3> pointsSeenBy(const frames::Frame& f) {
    std::vector<Vec3> P;
    for (double xn : {-0.45, -0.1, 0.0, 0.3, 0.5})
        for (double yn : {-0.35, 0.05, 0.4})
            for (double z : {4.0, 23.5, 90.0})
                P.push_back(frames::transformPoint(f.cameraToWorld, {xn * z, yn * z, z}));
    return P;
}

// Mucosa's own projection: the frames file's camera.
std::array<double, 2> mucosaPixel(const frames::Frame& f, const Vec3& P) {
    const Vec3 X = frames::transformPoint(frames::invertRigid(f.cameraToWorld), P);
    return frames::project(f.K, X[0] / X[2], X[1] / X[2]);
}

// --- reading the files ------------------------------------------------------

std::vector<std::string> lines(const fs::path& p) {
    std::ifstream in(p);
    EXPECT_TRUE(in.good()) << p;
    std::vector<std::string> out;
    for (std::string l; std::getline(in, l);) out.push_back(l);
    return out;
}

std::vector<std::string> words(const std::string& line) {
    std::istringstream s(line);
    std::vector<std::string> w;
    for (std::string x; s >> x;) w.push_back(x);
    return w;
}

// Hamilton quaternion (w, x, y, z) to a rotation matrix.
Mat3 hamilton(double w, double x, double y, double z) {
    const double n = std::sqrt(w * w + x * x + y * y + z * z);
    w /= n, x /= n, y /= n, z /= n;
    return {{{w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)},
             {2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)},
             {2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z}}};
}

Vec3 mul(const Mat3& R, const Vec3& v) {
    return {R[0][0] * v[0] + R[0][1] * v[1] + R[0][2] * v[2], R[1][0] * v[0] + R[1][1] * v[1] + R[1][2] * v[2],
            R[2][0] * v[0] + R[2][1] * v[1] + R[2][2] * v[2]};
}

Vec3 mulTransposed(const Mat3& R, const Vec3& v) {
    return {R[0][0] * v[0] + R[1][0] * v[1] + R[2][0] * v[2], R[0][1] * v[0] + R[1][1] * v[1] + R[2][1] * v[2],
            R[0][2] * v[0] + R[1][2] * v[1] + R[2][2] * v[2]};
}

double det(const Mat3& R) {
    return R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1]) - R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0]) +
           R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]);
}

Vec3 scaled(const Vec3& v, double s) {
    return {v[0] * s, v[1] * s, v[2] * s};
}

struct ColmapCamera {
    std::string model;
    int width = 0, height = 0;
    std::vector<double> params;
};

struct ColmapImage {
    Mat3 R{};  // world-to-camera
    Vec3 t{};
    int camera = 0;
    std::string name;
};

struct ColmapModel {
    std::map<int, ColmapCamera> cameras;
    std::vector<ColmapImage> images;
};

ColmapModel readColmap(const fs::path& dir) {
    ColmapModel m;
    for (const std::string& l : lines(dir / "cameras.txt")) {
        if (l.empty() || l[0] == '#') continue;
        const auto w = words(l);
        ColmapCamera c{w.at(1), std::stoi(w.at(2)), std::stoi(w.at(3)), {}};
        for (std::size_t i = 4; i < w.size(); ++i) c.params.push_back(std::stod(w[i]));
        m.cameras[std::stoi(w.at(0))] = c;
    }
    const auto ls = lines(dir / "images.txt");
    for (std::size_t i = 0; i < ls.size(); ++i) {
        if (ls[i].empty() || ls[i][0] == '#') continue;
        const auto w = words(ls[i]);
        EXPECT_EQ(w.size(), 10u) << ls[i];
        ColmapImage im;
        im.R = hamilton(std::stod(w.at(1)), std::stod(w.at(2)), std::stod(w.at(3)), std::stod(w.at(4)));
        im.t = {std::stod(w.at(5)), std::stod(w.at(6)), std::stod(w.at(7))};
        im.camera = std::stoi(w.at(8));
        im.name = w.at(9);
        EXPECT_EQ(std::stoul(w.at(0)), m.images.size() + 1) << "image ids count from 1";
        // The next line is the image's 2-D points: none.
        EXPECT_EQ(i + 1 < ls.size() ? ls[i + 1] : std::string("(end of file)"), "")
            << "the points2D line after image " << w[0];
        ++i;
        m.images.push_back(im);
    }
    return m;
}

// COLMAP's projection (src/colmap/sensor/models.h), in COLMAP pixels.
std::array<double, 2> colmapPixel(const ColmapCamera& c, const ColmapImage& im, const Vec3& Pw) {
    const Vec3 Rp = mul(im.R, Pw);
    const Vec3 X = {Rp[0] + im.t[0], Rp[1] + im.t[1], Rp[2] + im.t[2]};
    const double u = X[0] / X[2], v = X[1] / X[2];
    const auto& p = c.params;
    if (c.model == "PINHOLE") return {p.at(0) * u + p.at(2), p.at(1) * v + p.at(3)};
    EXPECT_EQ(c.model, "OPENCV");
    const double k1 = p.at(4), k2 = p.at(5), p1 = p.at(6), p2 = p.at(7);
    const double r2 = u * u + v * v, radialTerm = k1 * r2 + k2 * r2 * r2;
    const double du = u * radialTerm + 2 * p1 * u * v + p2 * (r2 + 2 * u * u);
    const double dv = v * radialTerm + 2 * p2 * u * v + p1 * (r2 + 2 * v * v);
    return {p.at(0) * (u + du) + p.at(2), p.at(1) * (v + dv) + p.at(3)};
}

// nerfstudio's camera (cameras.py _generate_rays_from_coords and
// camera_utils.py), inverted: the pixel whose ray passes through Pw, in
// nerfstudio pixels.
std::array<double, 2> nerfstudioPixel(const json& intr, const json& M, const Vec3& Pw) {
    Mat3 R{};
    Vec3 t{};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) R[r][c] = M[r][c].get<double>();
        t[r] = M[r][3].get<double>();
    }
    const Vec3 X = mulTransposed(R, {Pw[0] - t[0], Pw[1] - t[1], Pw[2] - t[2]});  // OpenGL camera axes
    EXPECT_LT(X[2], 0) << "in front of a nerfstudio camera is -z";
    // The ray direction is (x, -y, -1) for undistorted normalised (x, y).
    const double x = X[0] / -X[2], y = -X[1] / -X[2];
    const double k1 = intr["k1"], k2 = intr["k2"], k3 = intr["k3"], k4 = intr["k4"], p1 = intr["p1"], p2 = intr["p2"];
    const double r = x * x + y * y;
    const double d = 1 + r * (k1 + r * (k2 + r * (k3 + r * k4)));
    const double xd = d * x + 2 * p1 * x * y + p2 * (r + 2 * x * x);
    const double yd = d * y + 2 * p2 * x * y + p1 * (r + 2 * y * y);
    return {intr["fl_x"].get<double>() * xd + intr["cx"].get<double>(),
            intr["fl_y"].get<double>() * yd + intr["cy"].get<double>()};
}

json readJson(const fs::path& p) {
    std::ifstream in(p);
    return json::parse(in);
}

// The pixel one convention (top-left pixel centre at (0.5, 0.5)) gives, in
// Mucosa's (at (0, 0)).
std::array<double, 2> fromHalfPixelCentres(std::array<double, 2> p) {
    return {p[0] - 0.5, p[1] - 0.5};
}

void expectSamePixel(const std::array<double, 2>& got, const std::array<double, 2>& want, const std::string& what) {
    EXPECT_NEAR(got[0], want[0], kPixelTolerance) << what;
    EXPECT_NEAR(got[1], want[1], kPixelTolerance) << what;
}

std::string sameFile(const fs::path& p) {
    return fs::absolute(p).lexically_normal().generic_string();
}

ExportOptions options(const fs::path& source, std::optional<double> scale = std::nullopt) {
    ExportOptions o;
    o.source = source;
    o.imageRoot = source.parent_path();
    o.scale = scale;
    return o;
}

// --- COLMAP -------------------------------------------------------------------

TEST(DatasetExport, ColmapPointsLandWhereMucosaProjectsThem) {
    TempDir dir;
    const frames::FrameSet set = scene(dir / "video");
    for (double scale : {1.0, 0.001}) {
        const fs::path out = dir / ("sparse_" + std::to_string(scale));
        const Export e = exportFrames(set, ExportFormat::Colmap, out, options(dir / "frames.json", scale));
        EXPECT_EQ(e.frames, set.frames.size());
        EXPECT_EQ(e.cameras, 2u);
        const ColmapModel m = readColmap(out);
        ASSERT_EQ(m.images.size(), set.frames.size());
        ASSERT_EQ(m.cameras.size(), 2u) << "one camera per distinct intrinsics";
        for (std::size_t i = 0; i < set.frames.size(); ++i) {
            const frames::Frame& f = set.frames[i];
            const ColmapImage& im = m.images[i];
            const ColmapCamera& cam = m.cameras.at(im.camera);
            EXPECT_EQ(cam.model, f.K.k1 == 0 && f.K.k2 == 0 ? "PINHOLE" : "OPENCV");
            EXPECT_EQ(cam.width, f.K.width);
            EXPECT_EQ(cam.height, f.K.height);
            EXPECT_EQ(sameFile(dir / im.name), sameFile(f.image)) << "NAME is relative to the frames file's folder";
            EXPECT_NEAR(det(im.R), 1.0, 1e-12);
            for (const Vec3& P : pointsSeenBy(f))
                expectSamePixel(fromHalfPixelCentres(colmapPixel(cam, im, scaled(P, scale))), mucosaPixel(f, P),
                                "frame " + std::to_string(i) + ", scale " + std::to_string(scale));
        }
        // No 3-D points: comments only.
        for (const std::string& l : lines(out / "points3D.txt")) EXPECT_TRUE(l.empty() || l[0] == '#') << l;
    }
}

TEST(DatasetExport, ColmapCameraCentreIsMinusRTransposedT) {
    // format.rst: the projection centre is -R^T t; it must be the frame's
    // camera position.
    TempDir dir;
    const frames::FrameSet set = scene(dir.path());
    exportFrames(set, ExportFormat::Colmap, dir / "sparse", options(dir / "frames.json"));
    const ColmapModel m = readColmap(dir / "sparse");
    ASSERT_EQ(m.images.size(), set.frames.size());
    for (std::size_t i = 0; i < set.frames.size(); ++i) {
        const Vec3 C = mulTransposed(m.images[i].R, m.images[i].t);
        const frames::Vec3d want = frames::cameraCentre(set.frames[i].cameraToWorld);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(-C[k], want[k], 1e-10) << "frame " << i;
    }
}

TEST(DatasetExport, ColmapRefusesANameWithASpace) {
    TempDir dir;
    frames::FrameSet set = scene(dir.path(), false);
    set.frames[3].image = dir / "my frame.png";
    try {
        buildExport(set, ExportFormat::Colmap, dir / "sparse", options(dir / "frames.json"));
        FAIL() << "a NAME with a space was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(e.subject().find("frames[3].image"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(dir / "sparse"));
}

// --- TUM ----------------------------------------------------------------------

TEST(DatasetExport, TumPosesAreCameraToWorldInMetres) {
    TempDir dir;
    const frames::FrameSet set = scene(dir.path());
    ExportOptions o = options(dir / "frames.json");
    o.fps = 25;
    const Export e = exportFrames(set, ExportFormat::Tum, dir / "trajectory.txt", o);
    EXPECT_EQ(e.scale, 0.001) << "TUM's unit is the metre";
    std::vector<std::vector<double>> rows;
    bool headerSaysMetres = false;
    for (const std::string& l : lines(dir / "trajectory.txt")) {
        if (l.rfind('#', 0) == 0) {
            headerSaysMetres = headerSaysMetres || l.find("units: m ") != std::string::npos;
            continue;
        }
        std::vector<double> r;
        for (const std::string& w : words(l)) r.push_back(std::stod(w));
        ASSERT_EQ(r.size(), 8u) << l;
        rows.push_back(r);
    }
    EXPECT_TRUE(headerSaysMetres);
    ASSERT_EQ(rows.size(), set.frames.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {
        const auto& r = rows[i];
        const frames::Frame& f = set.frames[i];
        EXPECT_NEAR(r[0], static_cast<double>(i) / 25.0, 1e-6) << "timestamp of frame " << i;
        EXPECT_NEAR(r[4] * r[4] + r[5] * r[5] + r[6] * r[6] + r[7] * r[7], 1.0, 1e-12);
        const Mat3 R = hamilton(r[7], r[4], r[5], r[6]);  // qx qy qz qw: scalar last
        EXPECT_NEAR(det(R), 1.0, 1e-12);
        const Vec3 t = {r[1], r[2], r[3]};
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(t[k], f.cameraToWorld[k][3] * 0.001, 1e-15);
        for (const Vec3& P : pointsSeenBy(f)) {
            // Camera-to-world: the point in the camera is R^T (P - t), OpenCV axes.
            const Vec3 Pm = scaled(P, 0.001);
            const Vec3 X = mulTransposed(R, {Pm[0] - t[0], Pm[1] - t[1], Pm[2] - t[2]});
            const double xn = X[0] / X[2], yn = X[1] / X[2], r2 = xn * xn + yn * yn;
            const double s = 1 + f.K.k1 * r2 + f.K.k2 * r2 * r2;
            expectSamePixel({f.K.fx * xn * s + f.K.cx, f.K.fy * yn * s + f.K.cy}, mucosaPixel(f, P),
                            "frame " + std::to_string(i));
        }
    }
}

// --- nerfstudio ---------------------------------------------------------------

TEST(DatasetExport, NerfstudioPointsLandWhereMucosaProjectsThem) {
    TempDir dir;
    const frames::FrameSet set = scene(dir / "video");
    for (double scale : {1.0, 0.001}) {
        const fs::path out = dir / "ns" / ("transforms_" + std::to_string(scale) + ".json");
        fs::create_directories(out.parent_path());
        exportFrames(set, ExportFormat::Nerfstudio, out, options(dir / "frames.json", scale));
        const json j = readJson(out);
        EXPECT_EQ(j["camera_model"], "OPENCV");
        EXPECT_FALSE(j.contains("fl_x")) << "the intrinsics differ between frames: they go in each frame";
        EXPECT_EQ(j["mucosa"]["scale_per_mm"].get<double>(), scale);
        ASSERT_EQ(j["frames"].size(), set.frames.size());
        for (std::size_t i = 0; i < set.frames.size(); ++i) {
            const frames::Frame& f = set.frames[i];
            const json& fr = j["frames"][i];
            EXPECT_EQ(fr["w"], f.K.width);
            EXPECT_EQ(fr["h"], f.K.height);
            EXPECT_EQ(sameFile(out.parent_path() / fr["file_path"].get<std::string>()), sameFile(f.image))
                << "file_path is relative to transforms.json's folder";
            for (const Vec3& P : pointsSeenBy(f))
                expectSamePixel(fromHalfPixelCentres(nerfstudioPixel(fr, fr["transform_matrix"], scaled(P, scale))),
                                mucosaPixel(f, P), "frame " + std::to_string(i));
        }
    }
}

TEST(DatasetExport, NerfstudioMatrixIsOpenCvPoseWithYAndZFlipped) {
    TempDir dir;
    const frames::FrameSet set = scene(dir.path());
    exportFrames(set, ExportFormat::Nerfstudio, dir / "transforms.json", options(dir / "frames.json", 0.01));
    const json j = readJson(dir / "transforms.json");
    for (std::size_t i = 0; i < set.frames.size(); ++i) {
        const frames::Mat4& c2w = set.frames[i].cameraToWorld;
        const json& M = j["frames"][i]["transform_matrix"];
        Mat3 R{};
        for (int r = 0; r < 3; ++r) {
            EXPECT_NEAR(M[r][0].get<double>(), c2w[r][0], 1e-14) << "x stays";
            EXPECT_NEAR(M[r][1].get<double>(), -c2w[r][1], 1e-14) << "y flips: OpenGL's y is up";
            EXPECT_NEAR(M[r][2].get<double>(), -c2w[r][2], 1e-14) << "z flips: OpenGL's camera looks along -z";
            EXPECT_NEAR(M[r][3].get<double>(), c2w[r][3] * 0.01, 1e-12) << "translation in the chosen units";
            for (int c = 0; c < 3; ++c) R[r][c] = M[r][c];
        }
        for (int c = 0; c < 4; ++c) EXPECT_EQ(M[3][c].get<double>(), c == 3 ? 1.0 : 0.0);
        EXPECT_NEAR(det(R), 1.0, 1e-12) << "flipping two axes keeps the frame right-handed";
    }
}

TEST(DatasetExport, SharedIntrinsicsAreWrittenOnceAtTheTop) {
    TempDir dir;
    const frames::FrameSet set = scene(dir.path(), false);
    exportFrames(set, ExportFormat::Nerfstudio, dir.path(), options(dir / "frames.json"));
    const json j = readJson(dir / "transforms.json");  // a folder gets transforms.json
    const frames::Intrinsics K = pinhole();
    EXPECT_EQ(j["fl_x"], K.fx);
    EXPECT_EQ(j["fl_y"], K.fy);
    EXPECT_EQ(j["cx"], K.cx + 0.5);
    EXPECT_EQ(j["cy"], K.cy + 0.5);
    EXPECT_EQ(j["w"], K.width);
    EXPECT_EQ(j["h"], K.height);
    for (const char* k : {"k1", "k2", "k3", "k4", "p1", "p2"}) EXPECT_EQ(j[k], 0.0) << k;
    for (const json& f : j["frames"]) EXPECT_FALSE(f.contains("fl_x"));
    exportFrames(set, ExportFormat::Colmap, dir / "sparse", options(dir / "frames.json"));
    const ColmapModel m = readColmap(dir / "sparse");
    ASSERT_EQ(m.cameras.size(), 1u);
    EXPECT_EQ(m.cameras.at(1).model, "PINHOLE");
    EXPECT_EQ(m.cameras.at(1).params, (std::vector<double>{K.fx, K.fy, K.cx + 0.5, K.cy + 0.5}));
}

// --- quaternions and handedness -----------------------------------------------

TEST(DatasetExport, QuaternionRoundTripsThroughEveryBranch) {
    std::vector<Mat3> rotations = {axisAngle({1, 0, 0}, 0),         axisAngle({1, 0, 0}, M_PI),
                                   axisAngle({0, 1, 0}, M_PI),      axisAngle({0, 0, 1}, M_PI),
                                   axisAngle({1, 1, 0}, M_PI),      axisAngle({0, 1, 1}, M_PI - 1e-9),
                                   axisAngle({1, 0, 1}, -M_PI / 2), axisAngle({2, -1, 0.5}, 1e-12)};
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int i = 0; i < 500; ++i) rotations.push_back(axisAngle({u(rng), u(rng), u(rng)}, M_PI * u(rng)));
    for (const Mat3& R : rotations) {
        const Quaternion q = quaternionFromRotation(pose(R, {1, 2, 3}));
        EXPECT_NEAR(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z, 1.0, 1e-14);
        EXPECT_GE(q.w, 0.0);
        const Mat3 back = hamilton(q.w, q.x, q.y, q.z);
        const frames::Mat4 lib = rotationFromQuaternion(q);
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(back[r][c], R[r][c], 1e-14);
                EXPECT_NEAR(lib[r][c], R[r][c], 1e-14);
            }
        // And back again: the same quaternion (q and -q are one rotation).
        const Quaternion q2 = quaternionFromRotation(rotationFromQuaternion(q));
        const double dot = q.w * q2.w + q.x * q2.x + q.y * q2.y + q.z * q2.z;
        EXPECT_NEAR(std::fabs(dot), 1.0, 1e-14);
    }
}

TEST(DatasetExport, HalfTurnsAreNotMistakenForTheIdentity) {
    // A trace-only conversion divides by ~0 at a half turn; the quaternion
    // must be the axis itself.
    const Quaternion q = quaternionFromRotation(pose(axisAngle({0, 0, 1}, M_PI), {0, 0, 0}));
    EXPECT_NEAR(q.w, 0.0, 1e-15);
    EXPECT_NEAR(std::fabs(q.z), 1.0, 1e-15);
}

// --- bad input ----------------------------------------------------------------

// `mutate` breaks a good frame set; the exporter must refuse it with an
// InputError naming `mentions`, for every format, and write nothing.
template <typename F>
void expectRefused(F mutate, const std::string& mentions) {
    TempDir dir;
    frames::FrameSet set = scene(dir.path());
    mutate(set);
    for (ExportFormat format : {ExportFormat::Tum, ExportFormat::Colmap, ExportFormat::Nerfstudio}) {
        const fs::path out = dir / "out";
        try {
            exportFrames(set, format, format == ExportFormat::Colmap ? out : dir / "out.txt", options(dir / "f.json"));
            ADD_FAILURE() << exportFormatName(format) << " accepted a set with bad " << mentions;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(mentions), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("f.json"), std::string::npos) << "names the frames file: " << e.what();
        }
        EXPECT_FALSE(fs::exists(out)) << exportFormatName(format);
        EXPECT_FALSE(fs::exists(dir / "out.txt")) << exportFormatName(format);
    }
}

TEST(DatasetExport, RefusesAnEmptyFrameSet) {
    expectRefused([](frames::FrameSet& s) { s.frames.clear(); }, "'frames'");
}

TEST(DatasetExport, RefusesEveryFrameFlagged) {
    expectRefused(
        [](frames::FrameSet& s) {
            for (auto& f : s.frames) f.flagged = true;
        },
        "flagged");
}

TEST(DatasetExport, RefusesAReflection) {
    expectRefused(
        [](frames::FrameSet& s) {
            for (int r = 0; r < 3; ++r) s.frames[2].cameraToWorld[r][1] *= -1;  // det -1
        },
        "frames[2].camera_to_world");
}

TEST(DatasetExport, RefusesAScaledOrShearedRotation) {
    expectRefused(
        [](frames::FrameSet& s) {
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) s.frames[1].cameraToWorld[r][c] *= 1.01;
        },
        "frames[1].camera_to_world");
    expectRefused([](frames::FrameSet& s) { s.frames[4].cameraToWorld[0][1] += 0.05; }, "frames[4].camera_to_world");
}

TEST(DatasetExport, RefusesAProjectiveRowOrANaN) {
    expectRefused([](frames::FrameSet& s) { s.frames[0].cameraToWorld[3][2] = 0.1; }, "frames[0].camera_to_world");
    expectRefused([](frames::FrameSet& s) { s.frames[5].cameraToWorld[1][3] = std::nan(""); },
                  "frames[5].camera_to_world");
}

TEST(DatasetExport, RefusesUnusableIntrinsics) {
    expectRefused([](frames::FrameSet& s) { s.frames[3].K.fx = 0; }, "frames[3].intrinsics");
    expectRefused([](frames::FrameSet& s) { s.frames[3].K.k2 = INFINITY; }, "frames[3].intrinsics");
    expectRefused([](frames::FrameSet& s) { s.frames[0].K.width = 0; }, "frames[0].intrinsics");
}

TEST(DatasetExport, RefusesANonPositiveFpsOrScale) {
    TempDir dir;
    const frames::FrameSet set = scene(dir.path());
    ExportOptions o = options(dir / "f.json");
    o.fps = 0;
    EXPECT_THROW(buildExport(set, ExportFormat::Tum, dir / "t.txt", o), InputError);
    o.fps = 30;
    for (double s : {0.0, -1.0, std::nan("")}) {
        o.scale = s;
        EXPECT_THROW(buildExport(set, ExportFormat::Nerfstudio, dir / "t.json", o), InputError) << s;
    }
    EXPECT_THROW(parseExportFormat("blender"), InputError);
    EXPECT_EQ(parseExportFormat("colmap"), ExportFormat::Colmap);
}

TEST(DatasetExport, FlaggedFramesAreLeftOutAndKeepTheirTimes) {
    TempDir dir;
    frames::FrameSet set = scene(dir.path());
    set.frames[0].flagged = set.frames[5].flagged = true;
    const Export e = exportFrames(set, ExportFormat::Tum, dir / "t.txt", options(dir / "f.json"));
    EXPECT_EQ(e.frames, set.frames.size() - 2);
    EXPECT_EQ(e.skipped, 2u);
    std::vector<double> times;
    for (const std::string& l : lines(dir / "t.txt"))
        if (l.rfind('#', 0) != 0) times.push_back(std::stod(words(l).at(0)));
    ASSERT_EQ(times.size(), set.frames.size() - 2);
    EXPECT_NEAR(times[0], 1 / 30.0, 1e-6) << "frame 1 is first, at its own time";
    EXPECT_NEAR(times[4], 6 / 30.0, 1e-6) << "frame 5 is left out";
}

// --- the command line -----------------------------------------------------------

void expectOneErrorLine(const test::RunResult& r, const std::string& mentions) {
    EXPECT_NE(r.exitCode, 0);
    EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(mentions), std::string::npos) << r.err;
}

std::string quoted(const fs::path& p) {
    return fmt::format("'{}'", p.string());
}

TEST(DatasetExport, CliExportsWhatTheLibraryExports) {
    TempDir dir;
    const frames::FrameSet set = scene(dir / "video");
    frames::writeFrames(dir / "frames.json", set);
    const std::string frames = quoted(dir / "frames.json");
    auto r = test::runCli("dataset export " + frames + " --format tum -o " + quoted(dir / "t.txt") + " --fps 10");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("16 frames"), std::string::npos) << r.out;
    r = test::runCli("dataset export " + frames + " --format colmap -o " + quoted(dir / "sparse"));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("2 cameras"), std::string::npos) << r.out;
    r = test::runCli("dataset export " + frames + " --format nerfstudio -o " + quoted(dir / "transforms.json") +
                     " --scale 0.001");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("units m"), std::string::npos) << r.out;

    // The files the library writes from the same frames file, byte for byte.
    const frames::FrameSet read = frames::readFrames(dir / "frames.json");
    ExportOptions o = options(dir / "frames.json");
    o.fps = 10;
    EXPECT_EQ(test::readBytes(dir / "t.txt"), buildExport(read, ExportFormat::Tum, dir / "t.txt", o).files[0].text);
    const Export colmap = buildExport(read, ExportFormat::Colmap, dir / "sparse", options(dir / "frames.json"));
    for (const ExportFile& f : colmap.files) EXPECT_EQ(test::readBytes(f.path), f.text) << f.path;
    const Export ns =
        buildExport(read, ExportFormat::Nerfstudio, dir / "transforms.json", options(dir / "frames.json", 0.001));
    EXPECT_EQ(test::readBytes(dir / "transforms.json"), ns.files[0].text);
    // Written atomically: no temporary left beside them.
    for (const fs::path& d : {dir.path(), dir / "sparse"})
        for (const auto& entry : fs::directory_iterator(d))
            EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
}

TEST(DatasetExport, CliErrorsAreOneLineAndWriteNothing) {
    TempDir dir;
    frames::FrameSet set = scene(dir.path());
    frames::writeFrames(dir / "frames.json", set);
    const std::string frames = quoted(dir / "frames.json");
    fs::create_directories(dir / "keep");
    const fs::path existing = dir / "keep" / "t.txt";
    { std::ofstream(existing) << "an earlier trajectory\n"; }

    expectOneErrorLine(test::runCli("dataset export " + frames + " --format blender -o " + quoted(existing)),
                       "unknown format 'blender'");
    expectOneErrorLine(test::runCli("dataset export " + frames + " --format tum --fps 0 -o " + quoted(existing)),
                       "--fps");
    expectOneErrorLine(test::runCli("dataset export " + frames + " --format colmap --scale -2 -o " + quoted(dir / "s")),
                       "--scale");
    expectOneErrorLine(
        test::runCli("dataset export " + quoted(dir / "none.json") + " --format tum -o " + quoted(existing)),
        "none.json");
    expectOneErrorLine(test::runCli("dataset export " + frames + " --format colmap -o " + quoted(dir / "no" / "s")),
                       "does not exist");

    // A frames file whose pose is not rigid: the reader refuses it, naming
    // the field and the file.
    std::string text = test::readBytes(dir / "frames.json");
    json j = json::parse(text);
    j["frames"][2]["camera_to_world"][0][0] = 3.0;
    { std::ofstream(dir / "bad.json") << j.dump(1); }
    expectOneErrorLine(test::runCli("dataset export " + quoted(dir / "bad.json") + " --format colmap -o " +
                                    quoted(dir / "bad_sparse")),
                       "frames[2].camera_to_world");
    EXPECT_FALSE(fs::exists(dir / "bad_sparse")) << "no folder for a refused export";
    // Every frame flagged: refused, and the earlier file is untouched.
    for (auto& f : j["frames"]) {
        f["camera_to_world"] = json::parse(text)["frames"][0]["camera_to_world"];
        f["registration"] = {{"converged", false}};
    }
    { std::ofstream(dir / "flagged.json") << j.dump(1); }
    expectOneErrorLine(
        test::runCli("dataset export " + quoted(dir / "flagged.json") + " --format tum -o " + quoted(existing)),
        "flagged");
    EXPECT_EQ(test::readBytes(existing), "an earlier trajectory\n");
    std::size_t entries = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir / "keep")) ++entries;
    EXPECT_EQ(entries, 1u) << "no temporary left behind";
}

TEST(DatasetExport, DatasetIsACommandGroup) {
    const auto r = test::runCli("dataset");
    EXPECT_NE(r.exitCode, 0);
    EXPECT_EQ(test::runCli("dataset export --help").exitCode, 0);
}

}  // namespace
}  // namespace mucosa::dataset
