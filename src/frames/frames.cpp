#include <mucosa/frames/frames.hpp>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/shading/reference.hpp>

#include "core/json_parse.hpp"
#include "frames_json.hpp"

namespace mucosa::frames {

using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

double number(const json& j, const char* key, const std::string& where, const std::string& file, bool required,
              double fallback = 0) {
    if (!j.contains(key)) {
        if (required) throw InputError("field '" + where + key + "'", file, "is missing");
        return fallback;
    }
    if (!j[key].is_number()) throw InputError("field '" + where + key + "'", file, "must be a number");
    const double v = j[key].get<double>();
    if (!std::isfinite(v)) throw InputError("field '" + where + key + "'", file, "must be finite");
    return v;
}

Intrinsics parseIntrinsics(const json& k, const std::string& kw, const std::string& file) {
    Intrinsics K;
    const double w = number(k, "width", kw, file, true), h = number(k, "height", kw, file, true);
    if (w < 1 || h < 1 || w > 65536 || h > 65536 || w != std::floor(w) || h != std::floor(h))
        throw InputError("field '" + kw + "width/height'", file, "must be whole numbers in 1..65536");
    K.width = static_cast<int>(w);
    K.height = static_cast<int>(h);
    K.fx = number(k, "fx", kw, file, true);
    K.fy = number(k, "fy", kw, file, true);
    K.cx = number(k, "cx", kw, file, true);
    K.cy = number(k, "cy", kw, file, true);
    K.k1 = number(k, "k1", kw, file, false);
    K.k2 = number(k, "k2", kw, file, false);
    if (!(K.fx > 0) || !(K.fy > 0)) throw InputError("field '" + kw + "fx'", file, "focal lengths must be positive");
    return K;
}

Mat4 parseMatrix(const json& m, const std::string& field, const std::string& file) {
    if (!m.is_array() || m.size() != 4)
        throw InputError("field '" + field + "'", file, "must be a row-major 4x4 matrix");
    Mat4 M{};
    for (int r = 0; r < 4; ++r) {
        const json& row = m[r];
        if (!row.is_array() || row.size() != 4)
            throw InputError("field '" + field + "'", file, "must be a row-major 4x4 matrix");
        for (int c = 0; c < 4; ++c) {
            if (!row[c].is_number()) throw InputError("field '" + field + "'", file, "must hold numbers");
            M[r][c] = row[c].get<double>();
            if (!std::isfinite(M[r][c])) throw InputError("field '" + field + "'", file, "must hold finite numbers");
        }
    }
    // Rigid: orthonormal rotation with det +1, last row 0 0 0 1.
    const Rigidity rigid = rigidity(M);
    if (rigid.orthonormality > kRigidTolerance || rigid.determinant < 0 || M[3][0] != 0 || M[3][1] != 0 ||
        M[3][2] != 0 || M[3][3] != 1)
        throw InputError("field '" + field + "'", file,
                         "is not a rigid transform (rotation must be orthonormal with det +1, last row 0 0 0 1)");
    return M;
}

// units, gamma and light.offset: shared by frames and camera files.
void parseCommon(const json& j, const std::string& file, Response& response, Vec3d& lightOffset) {
    if (j.contains("units")) {
        if (!j["units"].is_string()) throw InputError("field 'units'", file, "must be a string");
        const std::string units = j["units"].get<std::string>();
        if (units != "mm")
            throw InputError("field 'units'", file, "'" + units + "' is not supported: give poses in mm");
    }
    response.gamma = number(j, "gamma", "", file, false, 1.0);
    if (!(response.gamma > 0)) throw InputError("field 'gamma'", file, "must be positive");
    response.vignetting = number(j, "vignetting", "", file, false, 0.0);
    if (!(response.vignetting >= 0 && response.vignetting <= 16))
        throw InputError("field 'vignetting'", file, "must be between 0 and 16 (k of cos^k of the field angle)");
    response.colourGain = number(j, "saturation", "", file, false, 1.0);
    if (!(response.colourGain >= 0 && response.colourGain <= 16))
        throw InputError("field 'saturation'", file,
                         "must be between 0 and 16 (the colour gain about the luma after the tone curve)");
    if (j.contains("tone_curve")) {
        const json& t = j["tone_curve"];
        for (int c = 0; c < 3 && t.is_string(); ++c)
            if (t.get<std::string>() == toneCurveName(c)) response.toneCurve = c;
        if (response.toneCurve < 0)
            throw InputError("field 'tone_curve'", file, "must be \"linear\", \"bt709\" or \"srgb\"");
        if (j.contains("gamma"))
            throw InputError("field 'gamma'", file, "and 'tone_curve' both say how to linearise: give one");
    }
    response.knee = number(j, "knee", "", file, false, 1.0);
    if (!(response.knee > 0 && response.knee <= 1))
        throw InputError("field 'knee'", file, "must be in (0, 1] (the highlight knee's output level; 1 = none)");
    if (response.knee != 1 && response.toneCurve < 0)
        throw InputError("field 'knee'", file, "needs a 'tone_curve' (the knee bends the camera's response)");
    response.flare = number(j, "flare", "", file, false, 0.0);
    if (!(response.flare >= 0 && response.flare <= 1))
        throw InputError("field 'flare'", file, "must be in 0..1 (the veiling glare's share of the mean radiance)");
    if (j.contains("light")) {
        const json& l = j["light"];
        if (!l.is_object()) throw InputError("field 'light'", file, "must be an object");
        if (l.contains("offset")) {
            if (!l["offset"].is_array() || l["offset"].size() != 3)
                throw InputError("field 'light.offset'", file, "must be 3 numbers (camera coordinates)");
            for (int i = 0; i < 3; ++i) {
                if (!l["offset"][i].is_number() || !std::isfinite(l["offset"][i].get<double>()))
                    throw InputError("field 'light.offset'", file, "must be finite numbers");
                lightOffset[i] = l["offset"][i].get<double>();
            }
        }
    }
}

}  // namespace

FrameSet readFrames(const fs::path& path, bool anyLens) {
    const std::string file = path.string();
    const json j = detail::parseJsonFile(readTextFile(path), file);
    if (!j.is_object()) throw InputError("frames file", file, "must be a JSON object");
    FrameSet set;
    parseCommon(j, file, set.response, set.lightOffset);
    if (j.contains("auto_exposure")) {
        if (!j["auto_exposure"].is_boolean()) throw InputError("field 'auto_exposure'", file, "must be true or false");
        set.autoExposure = j["auto_exposure"].get<bool>();
    }
    if (!j.contains("frames") || !j["frames"].is_array() || j["frames"].empty())
        throw InputError("field 'frames'", file, "must be a non-empty array");
    // A dataset rendered through a fisheye or omnidirectional lens carries it
    // here (mucosa render --lens); these frames are pinhole frames.
    if (!anyLens && j.contains("lens") && j["lens"].is_object() && j["lens"].contains("model") &&
        j["lens"]["model"].is_string() && j["lens"]["model"].get<std::string>() != "pinhole")
        throw InputError(
            "field 'lens'", file,
            fmt::format("is a {} lens; these tools read pinhole frames (intrinsics fx, fy, cx, cy, k1, k2)",
                        j["lens"]["model"].get<std::string>()));
    const fs::path dir = path.parent_path();
    for (std::size_t i = 0; i < j["frames"].size(); ++i) {
        const json& f = j["frames"][i];
        const std::string where = fmt::format("frames[{}].", i);
        if (!f.is_object())
            throw InputError("field '" + where.substr(0, where.size() - 1) + "'", file, "must be an object");
        Frame fr;
        if (!f.contains("image") || !f["image"].is_string())
            throw InputError("field '" + where + "image'", file, "must be a file name");
        fr.image = dir / f["image"].get<std::string>();
        if (!f.contains("intrinsics") || !f["intrinsics"].is_object())
            throw InputError("field '" + where + "intrinsics'", file, "is missing");
        fr.K = parseIntrinsics(f["intrinsics"], where + "intrinsics.", file);
        if (!f.contains("camera_to_world"))
            throw InputError("field '" + where + "camera_to_world'", file, "must be a row-major 4x4 matrix");
        fr.cameraToWorld = parseMatrix(f["camera_to_world"], where + "camera_to_world", file);
        if (f.contains("exposure")) {
            if (!f["exposure"].is_number() || !(f["exposure"].get<double>() > 0) ||
                !std::isfinite(f["exposure"].get<double>()))
                throw InputError("field '" + where + "exposure'", file,
                                 "must be a positive number (the camera's linear gain, 2^EV)");
            fr.exposure = f["exposure"].get<double>();
        }
        // `mucosa register` flags frames it could not register.
        if (f.contains("registration") && f["registration"].is_object() && f["registration"].contains("converged") &&
            f["registration"]["converged"].is_boolean())
            fr.flagged = !f["registration"]["converged"].get<bool>();
        set.frames.push_back(std::move(fr));
    }
    return set;
}

CameraModel readCamera(const fs::path& path) {
    const std::string file = path.string();
    const json j = detail::parseJsonFile(readTextFile(path), file);
    if (!j.is_object()) throw InputError("camera file", file, "must be a JSON object");
    CameraModel c;
    parseCommon(j, file, c.response, c.lightOffset);
    if (j.contains("light")) {
        c.lamp.spread = number(j["light"], "spread", "light.", file, false, 0.0);
        c.lamp.radiusMm = number(j["light"], "source_radius_mm", "light.", file, false, 0.0);
        if (!(c.lamp.spread >= 0 && c.lamp.spread <= 50))
            throw InputError("field 'light.spread'", file, "must be between 0 and 50 (mu of exp(-mu (1 - cos theta)))");
        if (!(c.lamp.radiusMm >= 0 && c.lamp.radiusMm <= 100))
            throw InputError("field 'light.source_radius_mm'", file, "must be between 0 and 100 mm");
        c.lamp.ambient = number(j["light"], "ambient", "light.", file, false, 0.0);
        if (!(c.lamp.ambient >= 0 && c.lamp.ambient <= 1))
            throw InputError("field 'light.ambient'", file,
                             "must be between 0 and 1 (of the lamp's irradiance at 10 mm)");
    }
    if (!j.contains("intrinsics") || !j["intrinsics"].is_object())
        throw InputError("field 'intrinsics'", file, "is missing (width, height, fx, fy, cx, cy[, k1, k2])");
    c.K = parseIntrinsics(j["intrinsics"], "intrinsics.", file);
    return c;
}

Mat4 readPose(const fs::path& path) {
    const std::string file = path.string();
    const json j = detail::parseJsonFile(readTextFile(path), file);
    if (!j.is_object()) throw InputError("pose file", file, "must be a JSON object");
    if (j.contains("camera_to_world")) return parseMatrix(j["camera_to_world"], "camera_to_world", file);
    Vec3d v[3];
    const char* keys[3] = {"position", "look_at", "up"};
    for (int k = 0; k < 3; ++k) {
        if (!j.contains(keys[k]) || !j[keys[k]].is_array() || j[keys[k]].size() != 3)
            throw InputError("field '" + std::string(keys[k]) + "'", file,
                             "must be 3 numbers (or give a row-major 4x4 'camera_to_world')");
        for (int i = 0; i < 3; ++i) {
            if (!j[keys[k]][i].is_number() || !std::isfinite(j[keys[k]][i].get<double>()))
                throw InputError("field '" + std::string(keys[k]) + "'", file, "must be finite numbers");
            v[k][i] = j[keys[k]][i].get<double>();
        }
    }
    try {
        return lookAtPose(v[0], v[1], v[2]);
    } catch (const InputError& e) {
        throw InputError(e.subject(), file, e.reason());
    }
}

Mat4 lookAtPose(const Vec3d& position, const Vec3d& lookAt, const Vec3d& up) {
    // OpenCV axes: z toward look_at, y down (so `up` is -y), x = y cross z.
    double z[3] = {lookAt[0] - position[0], lookAt[1] - position[1], lookAt[2] - position[2]};
    const double zn = std::sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
    if (!(zn > 1e-9)) throw InputError("field 'look_at'", "", "equals 'position'");
    for (double& c : z) c /= zn;
    const double ud = up[0] * z[0] + up[1] * z[1] + up[2] * z[2];
    double y[3] = {-(up[0] - ud * z[0]), -(up[1] - ud * z[1]), -(up[2] - ud * z[2])};
    const double yn = std::sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
    if (!(yn > 1e-9)) throw InputError("field 'up'", "", "is parallel to the viewing direction");
    for (double& c : y) c /= yn;
    const double x[3] = {y[1] * z[2] - y[2] * z[1], y[2] * z[0] - y[0] * z[2], y[0] * z[1] - y[1] * z[0]};
    Mat4 m{};
    for (int r = 0; r < 3; ++r) m[r] = {x[r], y[r], z[r], position[r]};
    m[3] = {0, 0, 0, 1};
    return m;
}

Rigidity rigidity(const Mat4& m) noexcept {
    Rigidity r;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            double dot = 0;
            for (int k = 0; k < 3; ++k) dot += m[k][a] * m[k][b];
            r.orthonormality = std::max(r.orthonormality, std::fabs(dot - (a == b ? 1.0 : 0.0)));
        }
    r.determinant = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                    m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                    m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    return r;
}

void writeFrames(const fs::path& path, const FrameSet& set, const json& extra) {
    json j{{"units", set.units}, {"light", {{"offset", set.lightOffset}}}, {"frames", json::array()}};
    writeResponse(j, set.response);
    if (set.autoExposure) j["auto_exposure"] = true;
    for (const Frame& f : set.frames) {
        json m = json::array();
        for (const auto& row : f.cameraToWorld) m.push_back(row);
        const json k = intrinsicsJson(f.K);
        json entry{{"image", relativePath(f.image, path.parent_path())}, {"intrinsics", k}, {"camera_to_world", m}};
        if (f.exposure > 0) entry["exposure"] = f.exposure;
        j["frames"].push_back(std::move(entry));
    }
    for (const auto& [key, value] : extra.items())
        if (!j.contains(key)) j[key] = value;
    writeFileAtomic(path, j.dump(2) + "\n");
}

json intrinsicsJson(const Intrinsics& K) {
    json k{{"width", K.width}, {"height", K.height}, {"fx", K.fx}, {"fy", K.fy}, {"cx", K.cx}, {"cy", K.cy}};
    if (K.k1 != 0 || K.k2 != 0) {
        k["k1"] = K.k1;
        k["k2"] = K.k2;
    }
    return k;
}

std::string relativePath(const fs::path& target, const fs::path& folder) {
    std::error_code ec;
    const fs::path base = fs::absolute(folder.empty() ? fs::path(".") : folder, ec);
    const fs::path rel = fs::relative(fs::absolute(target, ec), base, ec);
    return ec || rel.empty() ? fs::absolute(target).string() : rel.generic_string();
}

void writeResponse(nlohmann::json& j, const Response& response) {
    if (response.toneCurve >= 0)
        j["tone_curve"] = toneCurveName(response.toneCurve);
    else
        j["gamma"] = response.gamma;
    if (response.vignetting != 0) j["vignetting"] = response.vignetting;
    if (response.colourGain != 1) j["saturation"] = response.colourGain;
    if (response.knee != 1) j["knee"] = response.knee;
    if (response.flare != 0) j["flare"] = response.flare;
}

const char* toneCurveName(int curve) noexcept {
    constexpr const char* kNames[] = {"linear", "bt709", "srgb"};
    return curve >= 0 && curve < 3 ? kNames[curve] : "";
}

double Response::linear(double value) const noexcept {
    if (toneCurve >= 0)
        return shading::inverseToneCurve(shading::inverseKneeCurve(static_cast<float>(value), static_cast<float>(knee)),
                                         toneCurve);
    return gamma == 1.0 ? value : std::pow(value, gamma);
}

double Response::vignette(const Intrinsics& K, double x, double y) const noexcept {
    if (vignetting == 0) return 1.0;
    const double tx = (x - K.cx) / K.fx, ty = (y - K.cy) / K.fy;
    return std::pow(1.0 + tx * tx + ty * ty, -0.5 * vignetting);
}

namespace {

// Rec. 709 luma of tone-curved values (camera.glsl, enhanceColour).
double luma(const std::array<double, 3>& v) noexcept {
    return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
}

}  // namespace

std::array<double, 3> Response::enhance(const std::array<double, 3>& v) const noexcept {
    if (colourGain == 1) return v;
    const double y = luma(v);
    std::array<double, 3> out{};
    for (std::size_t c = 0; c < 3; ++c) out[c] = std::clamp(y + (v[c] - y) * colourGain, 0.0, 1.0);
    return out;
}

std::array<double, 3> Response::unenhance(const std::array<double, 3>& v) const noexcept {
    // Gain 0 made the frame grey, its luma: the colour does not come back.
    if (colourGain == 1 || colourGain == 0) return v;
    // The enhancement keeps the luma (its weights sum to 1): luma' = luma.
    const double y = luma(v);
    std::array<double, 3> out{};
    for (std::size_t c = 0; c < 3; ++c) out[c] = y + (v[c] - y) / colourGain;
    return out;
}

double Response::encode(double linear) const noexcept {
    if (toneCurve >= 0)
        return shading::kneeCurve(shading::toneCurve(static_cast<float>(linear), toneCurve), static_cast<float>(knee));
    return gamma == 1.0 ? linear : std::pow(linear, 1.0 / gamma);
}

Vec3d cameraCentre(const Mat4& m) noexcept {
    return {m[0][3], m[1][3], m[2][3]};
}

Mat4 invertRigid(const Mat4& m) noexcept {
    Mat4 r{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r[i][j] = m[j][i];
    for (int i = 0; i < 3; ++i) r[i][3] = -(r[i][0] * m[0][3] + r[i][1] * m[1][3] + r[i][2] * m[2][3]);
    r[3] = {0, 0, 0, 1};
    return r;
}

Vec3d transformPoint(const Mat4& m, const Vec3d& p) noexcept {
    return {m[0][0] * p[0] + m[0][1] * p[1] + m[0][2] * p[2] + m[0][3],
            m[1][0] * p[0] + m[1][1] * p[1] + m[1][2] * p[2] + m[1][3],
            m[2][0] * p[0] + m[2][1] * p[1] + m[2][2] * p[2] + m[2][3]};
}

Vec3d transformDirection(const Mat4& m, const Vec3d& d) noexcept {
    return {m[0][0] * d[0] + m[0][1] * d[1] + m[0][2] * d[2], m[1][0] * d[0] + m[1][1] * d[1] + m[1][2] * d[2],
            m[2][0] * d[0] + m[2][1] * d[1] + m[2][2] * d[2]};
}

std::array<double, 2> project(const Intrinsics& K, double xn, double yn) noexcept {
    // Brown-Conrady radial distortion (OpenCV's k1, k2).
    const double r2 = xn * xn + yn * yn;
    const double s = 1.0 + K.k1 * r2 + K.k2 * r2 * r2;
    return {K.fx * xn * s + K.cx, K.fy * yn * s + K.cy};
}

std::array<double, 2> unproject(const Intrinsics& K, double px, double py) noexcept {
    const double xd = (px - K.cx) / K.fx, yd = (py - K.cy) / K.fy;
    double x = xd, y = yd;
    for (int i = 0; i < 20; ++i) {  // fixed-point inversion, as OpenCV's undistortPoints
        const double r2 = x * x + y * y;
        const double s = 1.0 + K.k1 * r2 + K.k2 * r2 * r2;
        x = xd / s;
        y = yd / s;
    }
    return {x, y};
}

std::array<float, 16> glViewMatrix(const Mat4& c2w) {
    // OpenGL eye space = OpenCV camera space with y and z negated.
    const Mat4 w2c = invertRigid(c2w);
    std::array<float, 16> m{};
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) {
            const double s = (r == 1 || r == 2) ? -1.0 : 1.0;
            m[static_cast<std::size_t>(c * 4 + r)] = static_cast<float>(s * w2c[r][c]);
        }
    return m;
}

std::array<float, 16> glProjectionMatrix(const Intrinsics& K, double n, double f) {
    // x_ndc = 2 (u + 0.5) / w - 1 with u = fx X/Z + cx; y_ndc = 1 - 2 (v + 0.5) / h
    // (first row on top); X = xe, Y = -ye, Z = -ze (derivation in docs/theory.md).
    const double w = K.width, h = K.height;
    std::array<float, 16> m{};
    auto set = [&](int r, int c, double v) { m[static_cast<std::size_t>(c * 4 + r)] = static_cast<float>(v); };
    set(0, 0, 2 * K.fx / w);
    set(0, 2, 1 - 2 * (K.cx + 0.5) / w);
    set(1, 1, 2 * K.fy / h);
    set(1, 2, 2 * (K.cy + 0.5) / h - 1);
    set(2, 2, -(f + n) / (f - n));
    set(2, 3, -2 * f * n / (f - n));
    set(3, 2, -1);
    return m;
}

}  // namespace mucosa::frames
