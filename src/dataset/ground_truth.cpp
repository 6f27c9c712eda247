// Per-frame ground truth: see include/mucosa/dataset/ground_truth.hpp.
#include <mucosa/dataset/ground_truth.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/memory.hpp>
#include <mucosa/core/parallel.hpp>
#include <mucosa/dataset/raycast.hpp>
#include <mucosa/image/exr.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/raster/raster.hpp>

#include "core/json_parse.hpp"
#include "shading/glsl.hpp"

namespace mucosa::dataset {

namespace fs = std::filesystem;

namespace {

constexpr const char* kNames[] = {"rgb",  "depth", "normals", "mask",   "uv",
                                  "face", "flow",  "branch",  "linear", "highlight"};

bool* flag(Outputs& o, std::string_view name) {
    if (name == "rgb") return &o.rgb;
    if (name == "depth") return &o.depth;
    if (name == "normals") return &o.normals;
    if (name == "mask") return &o.mask;
    if (name == "uv") return &o.uv;
    if (name == "face") return &o.face;
    if (name == "flow") return &o.flow;
    if (name == "branch") return &o.branch;
    if (name == "linear") return &o.linear;
    if (name == "highlight") return &o.highlight;
    return nullptr;
}

bool has(const Outputs& o, std::string_view name) {
    return *flag(const_cast<Outputs&>(o), name);
}

// out.png -> out.<kind>.<ext> beside it.
fs::path beside(const fs::path& rgbName, const std::string& suffix) {
    fs::path p = rgbName;
    p.replace_filename(rgbName.stem().string() + suffix);
    return p;
}

// Pixel (x, y) sees triangle `tri` at barycentrics (b1, b2) and planar
// depth `depth`: its depth, normal (facing the camera, camera axes) and uv.
void fillPixel(GroundTruth& t, const mesh::Mesh& mesh, const frames::Mat4& c2w, int x, int y, std::int32_t tri,
               double b1, double b2, float depth) {
    const std::size_t i = static_cast<std::size_t>(y) * t.width + x;
    t.valid[i] = 1;
    t.face[i] = tri;
    t.b1[i] = static_cast<float>(b1);
    t.b2[i] = static_cast<float>(b2);
    t.depth.at(x, y) = depth;
    const std::uint32_t* v = &mesh.indices[3 * static_cast<std::size_t>(tri)];
    const double b0 = 1.0 - b1 - b2;
    // World normal: interpolated vertex normals, or the face's.
    double nw[3];
    const auto& p0 = mesh.positions[v[0]];
    const auto& p1 = mesh.positions[v[1]];
    const auto& p2 = mesh.positions[v[2]];
    if (mesh.normals.size() == mesh.positions.size()) {
        for (int k = 0; k < 3; ++k)
            nw[k] = b0 * mesh.normals[v[0]][k] + b1 * mesh.normals[v[1]][k] + b2 * mesh.normals[v[2]][k];
    } else {
        const double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        const double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
        nw[0] = e1[1] * e2[2] - e1[2] * e2[1];
        nw[1] = e1[2] * e2[0] - e1[0] * e2[2];
        nw[2] = e1[0] * e2[1] - e1[1] * e2[0];
    }
    // Facing the camera: against the ray from the eye to the point.
    const frames::Vec3d eye = frames::cameraCentre(c2w);
    double ray[3];
    for (int k = 0; k < 3; ++k) ray[k] = b0 * p0[k] + b1 * p1[k] + b2 * p2[k] - eye[k];
    if (nw[0] * ray[0] + nw[1] * ray[1] + nw[2] * ray[2] > 0)
        for (double& c : nw) c = -c;
    // To camera axes: R^T n (R = c2w's rotation).
    double nc[3], len = 0;
    for (int r = 0; r < 3; ++r) {
        nc[r] = c2w[0][r] * nw[0] + c2w[1][r] * nw[1] + c2w[2][r] * nw[2];
        len += nc[r] * nc[r];
    }
    len = std::sqrt(len);
    if (len > 0)
        for (int r = 0; r < 3; ++r) t.normals.at(x, y, r) = static_cast<float>(nc[r] / len);
    if (mesh.uvs.size() == mesh.positions.size()) {
        for (int k = 0; k < 2; ++k)
            t.uv.at(x, y, k) =
                static_cast<float>(b0 * mesh.uvs[v[0]][k] + b1 * mesh.uvs[v[1]][k] + b2 * mesh.uvs[v[2]][k]);
        t.uv.at(x, y, 2) = 1.f;
    }
}

}  // namespace

Outputs parseOutputs(std::string_view list, const std::string& what, const std::string& where) {
    Outputs o;
    o.rgb = false;
    bool any = false;
    std::size_t start = 0;
    while (start <= list.size()) {
        const std::size_t comma = std::min(list.find(',', start), list.size());
        std::string_view name = list.substr(start, comma - start);
        while (!name.empty() && name.front() == ' ') name.remove_prefix(1);
        while (!name.empty() && name.back() == ' ') name.remove_suffix(1);
        bool* f = flag(o, name);
        if (!f)
            throw InputError(
                what, where,
                fmt::format(
                    "unknown output '{}' (the outputs: rgb, linear, highlight, depth, normals, mask, uv, face, flow, "
                    "branch)",
                    std::string(name)));
        if (*f) throw InputError(what, where, fmt::format("'{}' is listed twice", std::string(name)));
        *f = any = true;
        start = comma + 1;
    }
    if (!any) throw InputError(what, where, "is empty");
    return o;
}

std::string outputNames(const Outputs& outputs) {
    std::string s;
    for (const char* n : kNames)
        if (has(outputs, n)) s += (s.empty() ? "" : ",") + std::string(n);
    return s;
}

frames::Intrinsics intrinsicsOf(const camera::Lens& lens, int width, int height) {
    // camera::projectionMatrix: the field of view spans the larger dimension
    // and the pixels are square; GL's pixel i has its centre at NDC
    // 2 (i + 0.5) / w - 1, which is OpenCV's u = i with cx = (w - 1) / 2.
    frames::Intrinsics K;
    K.width = width;
    K.height = height;
    K.fx = K.fy = 0.5 * std::max(width, height) / std::tan(0.5 * static_cast<double>(lens.fovDeg) * M_PI / 180.0);
    K.cx = 0.5 * (width - 1);
    K.cy = 0.5 * (height - 1);
    return K;
}

frames::Mat4 cameraToWorldOf(const camera::Pose& pose) {
    const frames::Vec3d eye{pose.position[0], pose.position[1], pose.position[2]};
    const frames::Vec3d at{eye[0] + pose.forward[0], eye[1] + pose.forward[1], eye[2] + pose.forward[2]};
    return frames::lookAtPose(eye, at, {pose.up[0], pose.up[1], pose.up[2]});
}

GroundTruth groundTruth(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& c2w, double nearMm,
                        int threads) {
    if (K.k1 != 0 || K.k2 != 0)
        throw InputError("intrinsics", "ground truth", "has radial distortion; ground truth is rendered for a pinhole");
    if (mesh.triangleCount() > (std::size_t{1} << 24))
        throw InputError("mesh", "ground truth",
                         fmt::format("has {} triangles; face ids are exact up to 2^24", mesh.triangleCount()));
    const std::size_t n = static_cast<std::size_t>(K.width) * K.height;
    // Per pixel: the z-buffer's 16 bytes, then depth, normals, uv, face and
    // two barycentrics (10 floats) and two masks.
    requireMemory(saturatingMul(n, 16 + 4 * 10 + 2), "ground truth");
    const frames::Mat4 w2c = frames::invertRigid(c2w);
    const raster::GBuffer g = raster::rasterize(mesh, K, w2c, nearMm, threads);
    GroundTruth t;
    t.width = K.width;
    t.height = K.height;
    t.depth = image::ImageF(K.width, K.height, 1);
    t.normals = image::ImageF(K.width, K.height, 3);
    t.uv = image::ImageF(K.width, K.height, 3);
    t.face.assign(n, -1);
    t.b1.assign(n, 0.f);
    t.b2.assign(n, 0.f);
    t.valid.assign(n, 0);
    t.inView.assign(n, 1);
    // Each pixel from its own z-buffer entry: the rows in parallel.
    tbb::task_arena arena(resolveThreads(threads));
    arena.execute([&] {
        tbb::parallel_for(0, K.height, [&](int y) {
            for (int x = 0; x < K.width; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * K.width + x;
                if (g.triangle[i] >= 0) fillPixel(t, mesh, c2w, x, y, g.triangle[i], g.b1[i], g.b2[i], g.depth[i]);
            }
        });
    });
    return t;
}

GroundTruth groundTruth(const RayCaster& caster, const Lens& lens, const frames::Mat4& c2w, double nearMm, int threads,
                        NearClip clip) {
    const mesh::Mesh& mesh = caster.mesh();
    if (mesh.triangleCount() > (std::size_t{1} << 24))
        throw InputError("mesh", "ground truth",
                         fmt::format("has {} triangles; face ids are exact up to 2^24", mesh.triangleCount()));
    const int w = lens.width, h = lens.height;
    const std::size_t n = static_cast<std::size_t>(w) * h;
    // Per pixel: depth, normals, uv, face and two barycentrics (10 floats)
    // and two masks.
    requireMemory(saturatingMul(n, 4 * 10 + 2), "ground truth");
    GroundTruth t;
    t.width = w;
    t.height = h;
    t.depth = image::ImageF(w, h, 1);
    t.normals = image::ImageF(w, h, 3);
    t.uv = image::ImageF(w, h, 3);
    t.face.assign(n, -1);
    t.b1.assign(n, 0.f);
    t.b2.assign(n, 0.f);
    t.valid.assign(n, 0);
    t.inView.assign(n, 0);
    const frames::Vec3d eye = frames::cameraCentre(c2w);
    // Each pixel is computed alone from its own ray, so the result does not
    // depend on how the rows are shared out.
    tbb::task_arena arena(resolveThreads(threads));
    arena.execute([&] {
        tbb::parallel_for(0, h, [&](int y) {
            for (int x = 0; x < w; ++x) {
                const std::optional<Vec3d> ray = unproject(lens, x, y);
                if (!ray) continue;
                const Vec3d& d = *ray;
                t.inView[static_cast<std::size_t>(y) * w + x] = 1;
                if (!(d[2] > 0)) continue;  // 90 degrees or more from the axis: no planar depth
                // The renderer's faces clip at nearMm along their own axis:
                // a cube face's is the ray's largest component, the one wide
                // face's the optical axis.
                const double axis =
                    clip == NearClip::Planar ? d[2] : std::max({std::fabs(d[0]), std::fabs(d[1]), d[2]});
                const frames::Vec3d dir = frames::transformDirection(c2w, d);
                const std::optional<Hit> hit = caster.firstHit(eye, dir, nearMm / axis);
                if (!hit) continue;
                fillPixel(t, mesh, c2w, x, y, hit->triangle, hit->b1, hit->b2, static_cast<float>(hit->t * d[2]));
            }
        });
    });
    return t;
}

GroundTruth groundTruth(const mesh::Mesh& mesh, const Lens& lens, const frames::Mat4& c2w, double nearMm, int threads,
                        NearClip clip) {
    return groundTruth(RayCaster(mesh), lens, c2w, nearMm, threads, clip);
}

namespace {

// The flow of `t` given each pixel's point (camera axes) from its depth and
// where a point of the previous camera's frame lands in its image.
template <class PointAt, class Project>
void flowWith(GroundTruth& t, const frames::Mat4& c2w, const GroundTruth* prev, const frames::Mat4& prevC2w,
              double nearMm, PointAt pointAt, Project projectTo) {
    t.flow = image::ImageF(t.width, t.height, 3);
    if (!prev) return;
    if (prev->width != t.width || prev->height != t.height)
        throw InputError("previous frame", "flow", "has another size");
    // This camera to the previous one: x_prev = W_prev * C * x (camera axes).
    const frames::Mat4 w2p = frames::invertRigid(prevC2w);
    frames::Mat4 m{};
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            for (int k = 0; k < 4; ++k) m[r][c] += w2p[r][k] * c2w[k][c];
    const int w = t.width, h = t.height;
    // Each pixel alone (the rows in parallel): the same result however they are shared out.
    tbb::parallel_for(0, h, [&](int y) {
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            if (!t.valid[i]) continue;
            const std::optional<frames::Vec3d> X = pointAt(x, y, static_cast<double>(t.depth.at(x, y)));
            if (!X) continue;
            double P[3];
            for (int r = 0; r < 3; ++r) P[r] = m[r][0] * (*X)[0] + m[r][1] * (*X)[1] + m[r][2] * (*X)[2] + m[r][3];
            if (!(P[2] > nearMm)) continue;
            const std::optional<PixelPoint> p = projectTo(frames::Vec3d{P[0], P[1], P[2]});
            if (!p) continue;
            const double u = p->u, v = p->v;
            t.flow.at(x, y, 0) = static_cast<float>(u - x);
            t.flow.at(x, y, 1) = static_cast<float>(v - y);
            if (!(u >= 0 && v >= 0 && u <= w - 1 && v <= h - 1)) continue;
            const int x0 = std::min(w - 2, static_cast<int>(u)), y0 = std::min(h - 2, static_cast<int>(v));
            const double ax = u - x0, ay = v - y0;
            double depth = 0, weight = 0;
            bool inView = false;
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx) {
                    const std::size_t j = static_cast<std::size_t>(y0 + dy) * w + x0 + dx;
                    const double wj = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
                    if (wj > 0 && prev->inView[j]) inView = true;
                    if (!prev->valid[j]) continue;
                    depth += wj * prev->depth.at(x0 + dx, y0 + dy);
                    weight += wj;
                }
            if (!inView || !(weight > 1e-9)) continue;
            depth /= weight;
            if (std::abs(depth - P[2]) <= 0.01 * P[2] + 0.01) t.flow.at(x, y, 2) = 1.f;
        }
    });
}

}  // namespace

void flowToPrevious(GroundTruth& t, const frames::Intrinsics& K, const frames::Mat4& c2w, const GroundTruth* prev,
                    const frames::Mat4& prevC2w, double nearMm) {
    flowWith(
        t, c2w, prev, prevC2w, nearMm,
        [&](int x, int y, double z) {
            return std::optional<frames::Vec3d>(frames::Vec3d{(x - K.cx) / K.fx * z, (y - K.cy) / K.fy * z, z});
        },
        [&](const frames::Vec3d& P) {
            return std::optional<PixelPoint>(PixelPoint{K.fx * P[0] / P[2] + K.cx, K.fy * P[1] / P[2] + K.cy});
        });
}

void flowToPrevious(GroundTruth& t, const Lens& lens, const frames::Mat4& c2w, const GroundTruth* prev,
                    const frames::Mat4& prevC2w, double nearMm) {
    flowWith(
        t, c2w, prev, prevC2w, nearMm,
        [&](int x, int y, double z) -> std::optional<frames::Vec3d> {
            const std::optional<Vec3d> d = unproject(lens, x, y);
            if (!d || !((*d)[2] > 1e-9)) return std::nullopt;
            const double s = z / (*d)[2];
            return frames::Vec3d{(*d)[0] * s, (*d)[1] * s, z};
        },
        [&](const frames::Vec3d& P) { return project(lens, P); });
}

std::vector<std::int32_t> vertexBranches(const mesh::Mesh& mesh, const mesh::Centerline& tree) {
    if (tree.branches.empty()) throw InputError("centerline", "branch labels", "has no branches");
    // Every segment with its radii (a branch without radii counts as radius 1).
    struct Segment {
        mesh::Vec3 a, b;
        float ra, rb;
        std::int32_t branch;
    };
    std::vector<Segment> segments;
    for (std::size_t bi = 0; bi < tree.branches.size(); ++bi) {
        const mesh::CenterlineBranch& br = tree.branches[bi];
        const bool radii = br.radii.size() == br.points.size();
        for (std::size_t k = 0; k < br.points.size(); ++k) {
            const std::size_t k1 = std::min(k + 1, br.points.size() - 1);
            if (k1 == k && br.points.size() > 1) break;
            segments.push_back({br.points[k], br.points[k1], radii ? br.radii[k] : 1.f, radii ? br.radii[k1] : 1.f,
                                static_cast<std::int32_t>(bi)});
        }
    }
    std::vector<std::int32_t> out(mesh.vertexCount(), 0);
    tbb::parallel_for(std::size_t{0}, mesh.vertexCount(), [&](std::size_t v) {
        const mesh::Vec3& p = mesh.positions[v];
        double best = std::numeric_limits<double>::infinity();
        for (const Segment& s : segments) {
            double d[3], e[3], ee = 0, de = 0;
            for (int k = 0; k < 3; ++k) d[k] = p[k] - s.a[k], e[k] = s.b[k] - s.a[k];
            for (int k = 0; k < 3; ++k) ee += e[k] * e[k], de += d[k] * e[k];
            const double f = ee > 0 ? std::clamp(de / ee, 0.0, 1.0) : 0.0;
            double dist2 = 0;
            for (int k = 0; k < 3; ++k) dist2 += (d[k] - f * e[k]) * (d[k] - f * e[k]);
            const double r = std::max(1e-3, s.ra + f * (s.rb - s.ra));
            const double score = dist2 / (r * r);
            if (score < best) best = score, out[v] = s.branch;
        }
    });
    return out;
}

void labelBranches(GroundTruth& t, const mesh::Mesh& mesh, const std::vector<std::int32_t>& vertexBranch) {
    if (vertexBranch.size() != mesh.vertexCount())
        throw InputError("branch labels", "ground truth", "are for another mesh");
    t.branch.assign(t.face.size(), -1);
    for (std::size_t i = 0; i < t.face.size(); ++i) {
        if (t.face[i] < 0) continue;
        const std::uint32_t* v = &mesh.indices[3 * static_cast<std::size_t>(t.face[i])];
        const float b0 = 1.f - t.b1[i] - t.b2[i];
        const int k = b0 >= t.b1[i] && b0 >= t.b2[i] ? 0 : t.b1[i] >= t.b2[i] ? 1 : 2;
        t.branch[i] = vertexBranch[v[k]];
    }
}

std::vector<std::uint8_t> fieldOfView(const shading::FrameSetup& frame) {
    const shading::glsl::Camera c = shading::glsl::packCamera(frame, 1.0f);
    std::vector<std::uint8_t> in(static_cast<std::size_t>(frame.width) * frame.height);
    // Coverage >= 1/2 at the pixel centre (GL's window coordinates: x + 1/2;
    // the mask is symmetric, so the rows' order does not matter).
    tbb::parallel_for(0, frame.height, [&](int y) {
        for (int x = 0; x < frame.width; ++x)
            in[static_cast<std::size_t>(y) * frame.width + x] =
                shading::glsl::fovMask(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, c) >= 0.5f;
    });
    return in;
}

image::Image8 highlightMask(const image::ImageF& with, const image::ImageF& without) {
    if (with.width() != without.width() || with.height() != without.height() || with.channels() != 3 ||
        without.channels() != 3)
        throw InputError("highlight mask", "", "needs two RGB images of one size");
    auto luminance = [](const image::ImageF& img, int x, int y) {
        return 0.2126f * img.at(x, y, 0) + 0.7152f * img.at(x, y, 1) + 0.0722f * img.at(x, y, 2);
    };
    image::Image8 mask(with.width(), with.height(), 1);
    for (int y = 0; y < with.height(); ++y)
        for (int x = 0; x < with.width(); ++x) {
            const float specular = luminance(with, x, y) - luminance(without, x, y);
            mask.at(x, y) = specular >= kHighlightMinSignal ? 255 : 0;
        }
    return mask;
}

std::vector<fs::path> outputFiles(const fs::path& rgbName, const Outputs& o) {
    std::vector<fs::path> files;
    if (o.rgb) files.push_back(rgbName);
    if (o.depth) files.push_back(beside(rgbName, ".depth.exr")), files.push_back(beside(rgbName, ".depth.png"));
    if (o.normals) files.push_back(beside(rgbName, ".normals.exr")), files.push_back(beside(rgbName, ".normals.png"));
    if (o.mask) files.push_back(beside(rgbName, ".mask.png"));
    if (o.uv) files.push_back(beside(rgbName, ".uv.exr"));
    if (o.face) files.push_back(beside(rgbName, ".face.exr"));
    if (o.flow) files.push_back(beside(rgbName, ".flow.exr")), files.push_back(beside(rgbName, ".occlusion.png"));
    if (o.branch) files.push_back(beside(rgbName, ".branch.png"));
    if (o.linear) files.push_back(beside(rgbName, ".linear.exr"));
    if (o.highlight) files.push_back(beside(rgbName, ".highlight.png"));
    if (hasRecord(o)) files.push_back(recordFile(rgbName));
    return files;
}

fs::path recordFile(const fs::path& rgbName) {
    return beside(rgbName, ".frame.json");
}

nlohmann::json frameRecord(int index, double exposure) {
    return {{"frame", index}, {"exposure", exposure}, {"exposure_ev", std::log2(exposure)}};
}

double readFrameExposure(const fs::path& path) {
    const std::string file = path.string();
    const nlohmann::json j = detail::parseJsonFile(readTextFile(path), file);
    if (!j.is_object() || !j.contains("exposure") || !j["exposure"].is_number())
        throw InputError("frame record", file, "has no number 'exposure'");
    const double e = j["exposure"].get<double>();
    if (!(e > 0 && std::isfinite(e))) throw InputError("field 'exposure'", file, "must be a positive number");
    return e;
}

void writeGroundTruth(const GroundTruth& t, const fs::path& rgbName, const Outputs& o, double depthScale) {
    if (!(depthScale > 0)) throw InputError("depth PNG scale", rgbName.string(), "must be positive");
    if (o.flow && (t.flow.width() != t.width || t.flow.height() != t.height))
        throw InputError("flow", rgbName.string(), "was not computed (flowToPrevious)");
    if (o.branch && t.branch.size() != t.face.size())
        throw InputError("branch", rgbName.string(), "was not labelled (labelBranches)");
    const int w = t.width, h = t.height;
    // Each file is converted, encoded and written as a task of its own: they
    // are independent, and one file's serial steps (the conversion, a PNG's
    // filtering) leave cores free for another's. The first error is thrown
    // once all have finished (each file is atomic: none is left half-written).
    tbb::task_group files;
    const image::ExrCompression exr = o.exrCompression;
    // zlib level 1 for the PNGs: a dataset's size is its EXRs', and level 6
    // costs a 16-bit depth PNG 6x the time for 30 % fewer bytes (640x480:
    // 26 ms for 79 KiB against 4 ms for 113 KiB).
    image::PngWriteOptions png1;
    png1.level = 1;
    if (o.depth) {
        files.run([&] { image::writeExr(beside(rgbName, ".depth.exr"), t.depth, exr); });
        files.run([&] {
            image::Image16 png(w, h, 1);
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x)
                    png.at(x, y) =
                        static_cast<std::uint16_t>(std::min(65535.0, std::round(t.depth.at(x, y) / depthScale)));
            image::writePng(beside(rgbName, ".depth.png"), png, png1);
        });
    }
    if (o.normals) {
        files.run([&] { image::writeExr(beside(rgbName, ".normals.exr"), t.normals, exr); });
        files.run([&] {
            image::Image16 png(w, h, 3);
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x)
                    for (int c = 0; c < 3; ++c)
                        png.at(x, y, c) =
                            t.valid[static_cast<std::size_t>(y) * w + x]
                                ? static_cast<std::uint16_t>(std::lround((t.normals.at(x, y, c) + 1.0) * 0.5 * 65535.0))
                                : 0;
            image::writePng(beside(rgbName, ".normals.png"), png, png1);
        });
    }
    if (o.mask)
        files.run([&] {
            image::Image8 png(w, h, 1);
            for (std::size_t i = 0; i < t.valid.size(); ++i) png.data()[i] = t.valid[i] && t.inView[i] ? 255 : 0;
            image::writePng(beside(rgbName, ".mask.png"), png, png1);
        });
    if (o.uv) files.run([&] { image::writeExr(beside(rgbName, ".uv.exr"), t.uv, exr); });
    if (o.face)
        files.run([&] {
            image::ImageF f(w, h, 1);
            for (std::size_t i = 0; i < t.face.size(); ++i) f.data()[i] = static_cast<float>(t.face[i]);
            image::writeExr(beside(rgbName, ".face.exr"), f, exr);
        });
    if (o.flow) {
        files.run([&] { image::writeExr(beside(rgbName, ".flow.exr"), t.flow, exr); });
        files.run([&] {
            image::Image8 png(w, h, 1);
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) png.at(x, y) = t.flow.at(x, y, 2) > 0 ? 0 : 255;
            image::writePng(beside(rgbName, ".occlusion.png"), png, png1);
        });
    }
    if (o.branch)
        files.run([&] {
            image::Image16 png(w, h, 1);
            for (std::size_t i = 0; i < t.branch.size(); ++i)
                png.data()[i] = static_cast<std::uint16_t>(std::clamp(t.branch[i] + 1, 0, 65535));
            image::writePng(beside(rgbName, ".branch.png"), png, png1);
        });
    files.wait();
}

nlohmann::json describeOutputs(const fs::path& output, int frames, const Outputs& o, double depthScale,
                               const mesh::Centerline* tree) {
    const std::string stem = output.stem().string() + (frames > 1 ? "_{frame:04}" : "");
    nlohmann::json j = nlohmann::json::object();
    const std::string none = "0 where the pixel sees no surface (mask.png)";
    auto exr = [&o](const char* channels) {
        return fmt::format("OpenEXR, {}, {} compression (lossless)", channels,
                           image::exrCompressionName(o.exrCompression));
    };
    if (o.rgb)
        j["rgb"] = {
            {"file", stem + output.extension().string()},
            {"encoding", fmt::format("{}-bit PNG, RGB, display-referred (the camera's tone curve applied)", o.rgbBits)},
            {"content", "the frame as the endoscope's camera puts it out (display-referred)"}};
    if (o.linear)
        j["linear"] = {
            {"file", stem + ".linear.exr"},
            {"encoding", exr("FLOAT channels 'R','G','B'")},
            {"unit", "sensor signal: 1 = full scale (saturation)"},
            {"content",
             "the camera's linear signal of the colour frame: the same exposure, vignetting, sensor noise and mask, "
             "before the tone curve and the colour enhancement (camera.saturation), without quantisation; "
             "clipped to [0, 1] as the sensor saturates"}};
    if (o.highlight)
        j["highlight"] = {
            {"file", stem + ".highlight.png"},
            {"encoding", "8-bit grey PNG"},
            {"content", fmt::format("255 where the pixel is a specular highlight: the specular reflection "
                                    "(material.specular_strength's lobe) adds at least {} of full scale to the "
                                    "luminance of the noise-free linear signal (after clipping); 0 elsewhere",
                                    kHighlightMinSignal)}};
    if (hasRecord(o))
        j["record"] = {
            {"file", stem + ".frame.json"},
            {"encoding", "JSON: {\"frame\": index, \"exposure\": gain, \"exposure_ev\": log2 of it}"},
            {"content",
             "the exposure the camera gave the frame: the linear gain applied to its sensor signal (2^EV, the "
             "metered value under auto-exposure, 2^camera.exposure_ev without; 1 in the modes without a camera); "
             "copied into this file's frames[i].exposure, which `mucosa fit` divides out"}};
    if (o.depth) {
        j["depth"] = {{"file", stem + ".depth.exr"},
                      {"encoding", exr("one FLOAT channel 'Y'")},
                      {"unit", "mm"},
                      {"content", "planar depth: z of the surface point along the optical axis (not the ray length)"},
                      {"invalid", none}};
        j["depth_png"] = {{"file", stem + ".depth.png"},
                          {"encoding", "16-bit grey PNG"},
                          {"unit", "mm"},
                          {"scale_mm", depthScale},
                          {"content", fmt::format("depth = value x {} mm; 65535 at and beyond {} mm", depthScale,
                                                  65535 * depthScale)},
                          {"invalid", "0"}};
    }
    if (o.normals) {
        j["normals"] = {{"file", stem + ".normals.exr"},
                        {"encoding", exr("FLOAT channels 'R','G','B' = x, y, z")},
                        {"axes", "camera space, OpenCV: x right, y down, z forward"},
                        {"content", "unit surface normal (the mesh's interpolated vertex normals), facing the camera"},
                        {"invalid", "0, 0, 0"}};
        j["normals_png"] = {{"file", stem + ".normals.png"},
                            {"encoding", "16-bit RGB PNG"},
                            {"axes", "camera space, OpenCV: x right, y down, z forward"},
                            {"content", "n = value / 65535 x 2 - 1 per channel"},
                            {"invalid", "0, 0, 0"}};
    }
    if (o.mask)
        j["mask"] = {{"file", stem + ".mask.png"},
                     {"encoding", "8-bit grey PNG"},
                     {"content",
                      "255 where the pixel is inside the scope's field-of-view mask and sees the airway's surface, 0 "
                      "elsewhere"}};
    if (o.uv)
        j["uv"] = {{"file", stem + ".uv.exr"},
                   {"encoding", exr("FLOAT channels 'R','G','B' = u, v, 1")},
                   {"content", "the mesh's texture coordinates (glTF/OpenGL: v up, the image's last row at v = 0)"},
                   {"invalid", "0, 0, 0 (also where the mesh has no texture coordinates)"}};
    if (o.face)
        j["face"] = {{"file", stem + ".face.exr"},
                     {"encoding", exr("one FLOAT channel 'Y'")},
                     {"content", "index of the mesh triangle seen (the mesh file's triangle order), exact integers"},
                     {"invalid", "-1"}};
    if (o.flow) {
        j["flow"] = {{"file", stem + ".flow.exr"},
                     {"encoding", exr("FLOAT channels 'R','G','B' = du, dv, visible")},
                     {"unit", "pixels"},
                     {"content",
                      "backward flow: where the pixel's surface point was in the previous frame minus where it is "
                      "(u_prev - u, v_prev - v), exact from depth and poses; visible = 1 where the point was seen in "
                      "the previous frame (within 1 % + 0.01 mm of its depth there, inside its view)"},
                     {"invalid", "visible = 0: occluded, outside the previous view, no surface, or the first frame"}};
        j["occlusion"] = {{"file", stem + ".occlusion.png"},
                          {"encoding", "8-bit grey PNG"},
                          {"content", "255 where the flow is not valid (flow.exr's visible = 0), 0 where it is"}};
    }
    if (o.branch) {
        nlohmann::json labels = nlohmann::json::array();
        if (tree)
            for (std::size_t b = 0; b < tree->branches.size(); ++b) {
                const mesh::CenterlineBranch& br = tree->branches[b];
                labels.push_back({{"value", b + 1},
                                  {"name", br.name},
                                  {"generation", br.generation},
                                  {"parent", br.parent >= 0 ? nlohmann::json(br.parent + 1) : nlohmann::json(0)}});
            }
        j["branch"] = {{"file", stem + ".branch.png"},
                       {"encoding", "16-bit grey PNG"},
                       {"content",
                        "the airway branch the pixel sees: value = the centerline branch's index + 1 (the labels "
                        "below: name, generation (0 trachea, 1 main bronchi, 2 lobar, 3 segmental), parent's value); "
                        "each wall vertex belongs to the branch whose centerline passes nearest in units of its "
                        "lumen radius"},
                       {"invalid", "0 where no surface"},
                       {"labels", labels}};
    }
    return j;
}

}  // namespace mucosa::dataset
