#include <mucosa/register/register.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <random>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <Eigen/Dense>

#include <mucosa/core/error.hpp>
#include <mucosa/core/parallel.hpp>
#include <mucosa/fit/fit.hpp>

namespace mucosa::registration {

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Separable Gaussian with zero padding (the moments of the local fit).
void gaussianBlur(std::vector<double>& v, int w, int h, double sigma) {
    const int r = std::max(1, static_cast<int>(std::ceil(3 * sigma)));
    std::vector<double> k(2 * r + 1);
    double sum = 0;
    for (int i = -r; i <= r; ++i) sum += k[i + r] = std::exp(-0.5 * i * i / (sigma * sigma));
    for (double& x : k) x /= sum;
    std::vector<double> t(v.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double a = 0;
            for (int i = std::max(-r, -x); i <= std::min(r, w - 1 - x); ++i)
                a += k[i + r] * v[static_cast<std::size_t>(y) * w + x + i];
            t[static_cast<std::size_t>(y) * w + x] = a;
        }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double a = 0;
            for (int i = std::max(-r, -y); i <= std::min(r, h - 1 - y); ++i)
                a += k[i + r] * t[static_cast<std::size_t>(y + i) * w + x];
            v[static_cast<std::size_t>(y) * w + x] = a;
        }
}

// Grey-scale dilation (max) or erosion (min) over a (2r+1)^2 square of the
// usable pixels (separable); unusable pixels neither take part nor change.
void morphology(image::ImageF& img, const std::vector<std::uint8_t>& use, int r, bool dilate) {
    const int w = img.width(), h = img.height();
    const float none = dilate ? -std::numeric_limits<float>::infinity() : std::numeric_limits<float>::infinity();
    auto pick = [dilate](float a, float b) { return dilate ? std::max(a, b) : std::min(a, b); };
    std::vector<float> t(img.size(), none);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float v = none;
            for (int i = std::max(0, x - r); i <= std::min(w - 1, x + r); ++i) {
                const std::size_t j = static_cast<std::size_t>(y) * w + i;
                if (use[j]) v = pick(v, img.data()[j]);
            }
            t[static_cast<std::size_t>(y) * w + x] = v;
        }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t o = static_cast<std::size_t>(y) * w + x;
            if (!use[o]) continue;
            float v = none;
            for (int i = std::max(0, y - r); i <= std::min(h - 1, y + r); ++i)
                v = pick(v, t[static_cast<std::size_t>(i) * w + x]);
            if (std::isfinite(v)) img.data()[o] = v;
        }
}

// Thin dark vessels and small bright glints are albedo and specularity, not
// shape: a grey-scale opening then closing of radius r removes them and
// leaves shading that varies over a larger scale nearly as is. Both sides
// are filtered alike.
image::ImageF openClose(const image::ImageF& E, const std::vector<std::uint8_t>& use, int r) {
    image::ImageF f = E;
    if (r <= 0) return f;
    morphology(f, use, r, false);  // opening: erode ...
    morphology(f, use, r, true);   // ... then dilate
    morphology(f, use, r, true);   // closing: dilate ...
    morphology(f, use, r, false);  // ... then erode
    return f;
}

// The closed-form solve: log-intensity derivatives (per unit of normalised
// image coordinate) at (x, y) -> the normal (a, b, -c) up to scale, with c =
// 1 + a x + b y (p = a / c, q = b / c), or nothing if masked. The normal is
// defined at any c (c = 0: a wall parallel to the optical axis, which looking
// down a bronchus is most of it); the mask is on the normal's cosine to the
// ray (x, y, 1), 1 / (|(a, b, c)| |(x, y, 1)|): grazing walls, occluding
// contours and folds, where the plane breaks. `grazing`: no mask (the
// model's side: a wall it sees is a wall, however it is seen).
std::optional<std::array<double, 3>> solvePq(double gx, double gy, double xn, double yn, const PqOptions& o,
                                             bool grazing = false) {
    const double S = 1 + xn * xn + yn * yn;
    const double a = -gx / 3 - xn / S, b = -gy / 3 - yn / S;
    const double c = 1 + a * xn + b * yn;
    if (!grazing && 1 / std::sqrt((a * a + b * b + c * c) * S) < o.minRayCosine) return std::nullopt;
    return std::array<double, 3>{a, b, c};
}

// The estimator, both sides. `E`: linear irradiance; `use`: pixels that may
// be used; `darkLevel`: the video's dark lumen (its weight's brightness term);
// `grazing`: the model's side (no mask on the normal, weight 1).
PqField estimate(const image::ImageF& E, std::vector<std::uint8_t> use, const frames::Intrinsics& K, const PqOptions& o,
                 double darkLevel, bool grazing = false) {
    const int w = E.width(), h = E.height();
    const std::size_t n = static_cast<std::size_t>(w) * h;
    PqField f;
    f.width = w;
    f.height = h;
    f.p.assign(n, 0.f);
    f.q.assign(n, 0.f);
    f.weight.assign(n, 0.f);
    f.normal.assign(n, {0.f, 0.f, 0.f});
    std::vector<float> L(n, 0.f);
    for (std::size_t i = 0; i < n; ++i) {
        const float e = E.data()[i];
        if (!(e > 0) || !std::isfinite(e)) use[i] = 0;
        if (use[i]) L[i] = std::log(e);
    }
    f.usable = use;
    // The log-intensity's gradient at each pixel: the slope of a plane fitted
    // to ln E by Gaussian-weighted least squares over the usable pixels around
    // it (a masked local-linear fit: unlike smoothing then differencing, it is
    // unbiased next to the mask's edge where the window is one-sided). The
    // moments come from separable convolutions of m, m x, m y, m x^2, m y^2,
    // m x y, m L, m L x, m L y (absolute coordinates, centred algebraically).
    enum { M1, MX, MY, MXX, MYY, MXY, ML, MLX, MLY, kMoments };
    std::vector<std::vector<double>> mom(kMoments, std::vector<double>(n, 0.0));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            if (!use[i]) continue;
            const double fx = x, fy = y;
            mom[M1][i] = 1, mom[MX][i] = fx, mom[MY][i] = fy, mom[MXX][i] = fx * fx, mom[MYY][i] = fy * fy;
            mom[MXY][i] = fx * fy, mom[ML][i] = L[i], mom[MLX][i] = L[i] * fx, mom[MLY][i] = L[i] * fy;
        }
    for (auto& m : mom) gaussianBlur(m, w, h, std::max(0.5, o.smoothingPx));
    const double fullMass = 1.0;  // the kernel is normalised
    const int b = std::max(1, o.borderPx);
    const double smoothing4 = std::pow(o.smoothingPx, 4);
    for (int y = b; y < h - b; ++y)
        for (int x = b; x < w - b; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            if (!use[i]) continue;
            const double s1 = mom[M1][i];
            if (s1 < 0.35 * fullMass) continue;                               // too little of the window is usable
            const double mx = mom[MX][i] / s1 - x, my = mom[MY][i] / s1 - y;  // centroid offset
            // Centred second moments (about the pixel) and cross-moments with L.
            const double sxx = mom[MXX][i] - 2.0 * x * mom[MX][i] + double(x) * x * s1;
            const double syy = mom[MYY][i] - 2.0 * y * mom[MY][i] + double(y) * y * s1;
            const double sxy = mom[MXY][i] - x * mom[MY][i] - y * mom[MX][i] + double(x) * y * s1;
            const double sl = mom[ML][i];
            const double slx = mom[MLX][i] - x * sl, sly = mom[MLY][i] - y * sl;
            // Normal equations of L ~ c + gu du + gv dv with du = u - x, dv = v - y.
            // The symmetric 3x3 system solved by its cofactors (c_ij), which
            // the determinant's test below needs anyway.
            const double a11 = s1, a12 = s1 * mx, a13 = s1 * my, a22 = sxx, a23 = sxy, a33 = syy;
            const double c11 = a22 * a33 - a23 * a23, c12 = a13 * a23 - a12 * a33, c13 = a12 * a23 - a13 * a22;
            const double det = a11 * c11 + a12 * c12 + a13 * c13;
            // A window cut to a line cannot give a 2D slope.
            if (std::abs(det) < 1e-3 * s1 * s1 * s1 * smoothing4) continue;
            const double c22 = a11 * a33 - a13 * a13, c23 = a12 * a13 - a11 * a23, c33 = a11 * a22 - a12 * a12;
            const double g1 = (c12 * sl + c22 * slx + c23 * sly) / det, g2 = (c13 * sl + c23 * slx + c33 * sly) / det;
            // d lnE / d(normalised x) = d lnE / du * fx.
            const double gx = g1 * K.fx, gy = g2 * K.fy;
            const auto abc = solvePq(gx, gy, (x - K.cx) / K.fx, (y - K.cy) / K.fy, o, grazing);
            if (!abc) continue;
            const auto [a, bb, cond] = *abc;
            const double held = std::max(cond, 0.01);  // p, q for display past the axis-parallel wall
            f.p[i] = static_cast<float>(a / held);
            f.q[i] = static_cast<float>(bb / held);
            const double norm = std::sqrt(a * a + bb * bb + cond * cond);
            f.normal[i] = {static_cast<float>(a / norm), static_cast<float>(bb / norm),
                           static_cast<float>(-cond / norm)};
            // Brightness: the log-gradient's noise grows as the signal falls.
            // (The model's side, noiseless, takes weight 1 wherever it has an estimate.)
            const double e = E.data()[i];
            f.weight[i] = grazing ? 1.f : static_cast<float>(e / (e + 2 * darkLevel));
        }
    return f;
}

double percentile(std::vector<float> v, double q) {
    if (v.empty()) return 0;
    const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

using Mat3 = Eigen::Matrix3d;

Mat3 rotationOf(const frames::Mat4& m) {
    Mat3 R;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R(r, c) = m[r][c];
    return R;
}

Mat3 rodrigues(const frames::Vec3d& w) {
    const Eigen::Vector3d v(w[0], w[1], w[2]);
    const double a = v.norm();
    if (a < 1e-12) return Mat3::Identity();
    return Eigen::AngleAxisd(a, v / a).toRotationMatrix();
}

// A frame's neighbourhood as a small mesh (positions, normals, indices).
// `kept` (optional): each of its vertices' index in `m`.
mesh::Mesh submesh(const mesh::Mesh& m, const std::vector<std::uint32_t>& tris,
                   std::vector<std::uint32_t>* kept = nullptr) {
    mesh::Mesh s;
    if (kept) kept->clear();
    std::vector<std::int64_t> remap(m.vertexCount(), -1);
    s.indices.reserve(tris.size() * 3);
    for (std::uint32_t t : tris)
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = m.indices[3 * static_cast<std::size_t>(t) + k];
            if (remap[v] < 0) {
                remap[v] = static_cast<std::int64_t>(s.positions.size());
                s.positions.push_back(m.positions[v]);
                s.normals.push_back(m.normals[v]);
                if (m.hasUvs()) s.uvs.push_back(m.uvs[v]);  // for a model texture
                if (kept) kept->push_back(v);
            }
            s.indices.push_back(static_cast<std::uint32_t>(remap[v]));
        }
    return s;
}

// The neighbourhood and the options to register in it: an albedo per vertex
// (AlbedoMap) follows its vertices into the small mesh.
struct Neighbourhood {
    mesh::Mesh mesh;
    RegisterOptions options;
};
Neighbourhood neighbourhood(const mesh::Mesh& m, const frames::Vec3d& centre, double radius, const RegisterOptions& o) {
    Neighbourhood n;
    n.options = o;
    const bool perVertex = o.texture && !o.texture->perVertex.empty();
    std::vector<std::uint32_t> kept;
    n.mesh = submesh(m, trianglesNear(m, centre, radius), perVertex ? &kept : nullptr);
    if (perVertex) {
        if (o.texture->perVertex.size() != m.vertexCount())
            throw InputError("model texture", "registration", "has an albedo for a different number of vertices");
        auto t = std::make_shared<ModelTexture>();
        t->perVertex.reserve(kept.size());
        for (std::uint32_t v : kept) t->perVertex.push_back(o.texture->perVertex[v]);
        n.options.texture = std::move(t);
    }
    return n;
}

constexpr double kUnseen2 = 0.3;  // |n_video - n_model|^2 charged for a pixel the model does not see

struct Objective {
    double cauchy2 = 0.25;  // squared scale of the Cauchy loss
    const mesh::Mesh& mesh;
    const VideoFrame::Level& level;
    const RegisterOptions& o;
    std::vector<std::size_t> pixels;  // the residual's pixels (fixed for the level)
    double videoMean = 0, videoStd = 1;
    FrameRegistration* stats;  // timing and render counts go here

    Objective(const mesh::Mesh& m, const VideoFrame::Level& l, const RegisterOptions& opt, FrameRegistration& st)
        : cauchy2(opt.robustScale * opt.robustScale), mesh(m), level(l), o(opt), stats(&st) {
        const std::size_t n = static_cast<std::size_t>(l.K.width) * l.K.height;
        if (o.method == RegistrationMethod::PqSpace) {
            for (std::size_t i = 0; i < n; ++i)
                if (l.pq.weight[i] > 0) pixels.push_back(i);
        } else {
            double s = 0, s2 = 0;
            for (std::size_t i = 0; i < n; ++i)
                if (l.valid[i]) {
                    pixels.push_back(i);
                    s += l.luminance.data()[i];
                    s2 += double(l.luminance.data()[i]) * l.luminance.data()[i];
                }
            const double count = static_cast<double>(std::max<std::size_t>(1, pixels.size()));
            videoMean = s / count;
            videoStd = std::sqrt(std::max(1e-20, s2 / count - videoMean * videoMean));
        }
    }

    // Per-pixel difference vectors at a pose (3 per pixel for pq, 1 for
    // intensity) and the similarity there.
    // `seen` (optional): 1 where the model has an estimate at the pixel.
    std::vector<double> differences(const frames::Mat4& pose, double* similarity,
                                    std::vector<std::uint8_t>* seen = nullptr) {
        auto t0 = Clock::now();
        const ModelView view = renderModel(mesh, level.K, pose, o.lightOffset, 1, o.supersample, o.lamp,
                                           o.brdf ? &*o.brdf : nullptr, o.texture.get());
        stats->renderSeconds += secondsSince(t0);
        ++stats->evaluations;
        t0 = Clock::now();
        std::vector<double> d;
        if (o.method == RegistrationMethod::PqSpace) {
            const PqField m = pqFromModel(view, level.K, level.pqOptions, &level.pq.usable);
            d.resize(3 * pixels.size());
            if (seen) seen->assign(pixels.size(), 0);
            double sw = 0, sc = 0;
            for (std::size_t k = 0; k < pixels.size(); ++k) {
                const std::size_t i = pixels[k];
                const auto& nv = level.pq.normal[i];
                const Eigen::Vector3d a(nv[0], nv[1], nv[2]);
                Eigen::Vector3d diff;
                double c = 0;
                if (m.weight[i] > 0) {
                    const auto& nm = m.normal[i];
                    const Eigen::Vector3d bv(nm[0], nm[1], nm[2]);
                    diff = a - bv;
                    c = a.dot(bv);
                    if (seen) (*seen)[k] = 1;
                } else {
                    // Unseen by the model (beyond its edge, an occluding
                    // contour's rim): a fixed, moderate cost (that of 33
                    // degrees). A large one makes the cost jump as pixels cross
                    // a contour and hides the smooth part from the solver;
                    // none would reward looking past the mesh.
                    diff = a * std::sqrt(kUnseen2);
                }
                for (int j = 0; j < 3; ++j) d[3 * k + j] = diff[j];
                sw += level.pq.weight[i];
                sc += level.pq.weight[i] * c;
            }
            if (similarity) *similarity = sw > 0 ? sc / sw : 0;
        } else {
            double s = 0, s2 = 0;
            for (std::size_t i : pixels) {
                s += view.shading.data()[i];
                s2 += double(view.shading.data()[i]) * view.shading.data()[i];
            }
            const double n = static_cast<double>(std::max<std::size_t>(1, pixels.size()));
            const double mm = s / n, sd = std::sqrt(std::max(1e-30, s2 / n - mm * mm));
            d.resize(pixels.size());
            if (seen) seen->assign(pixels.size(), 1);
            double ncc = 0;
            for (std::size_t k = 0; k < pixels.size(); ++k) {
                const std::size_t i = pixels[k];
                const double zv = (level.luminance.data()[i] - videoMean) / videoStd;
                const double zm = (view.shading.data()[i] - mm) / sd;
                d[k] = (zv - zm) / std::sqrt(n);
                ncc += zv * zm / n;
            }
            if (similarity) *similarity = ncc;
        }
        stats->similaritySeconds += secondsSince(t0);
        return d;
    }

    int block() const { return o.method == RegistrationMethod::PqSpace ? 3 : 1; }
    double weight(std::size_t k) const {
        return o.method == RegistrationMethod::PqSpace ? level.pq.weight[pixels[k]] : 1.0;
    }
};

// Cauchy loss on the per-pixel difference norm (pq: |n_video - n_model|^2 =
// 2 - 2 cos): a pixel whose model normal is far off (a specular streak, a
// vessel edge) stops pulling once it is clearly an outlier.

double robustCost(const Objective& obj, const std::vector<double>& d) {
    const int b = obj.block();
    double c = 0;
    for (std::size_t k = 0; k < obj.pixels.size(); ++k) {
        double e2 = 0;
        for (int j = 0; j < b; ++j) e2 += d[b * k + j] * d[b * k + j];
        c += obj.o.method == RegistrationMethod::PqSpace ? obj.weight(k) * obj.cauchy2 * std::log1p(e2 / obj.cauchy2)
                                                         : e2;
    }
    return c;
}

}  // namespace

const char* methodName(RegistrationMethod m) noexcept {
    return m == RegistrationMethod::PqSpace ? "pq" : "intensity";
}

PqField pqFromShading(const image::ImageF& linear, const frames::Intrinsics& K, const PqOptions& o,
                      const std::vector<std::uint8_t>* valid) {
    const std::size_t n = static_cast<std::size_t>(linear.width()) * linear.height();
    std::vector<float> inside;
    inside.reserve(n);
    for (std::size_t i = 0; i < n; ++i)
        if (!valid || (*valid)[i]) inside.push_back(linear.data()[i]);
    const double dark = o.darkFraction * percentile(inside, 0.99);
    std::vector<std::uint8_t> use(n);
    for (std::size_t i = 0; i < n; ++i) {
        const float e = linear.data()[i];
        use[i] = (!valid || (*valid)[i]) && e > dark && e < o.saturation;
    }
    const image::ImageF filtered = openClose(linear, use, o.albedoFilterPx);
    return estimate(filtered, std::move(use), K, o, dark);
}

double ModelTexture::at(double u, double v) const noexcept {
    const int w = luminance.width(), h = luminance.height();
    if (w == 0 || h == 0) return 1.0;
    double fu = (u - uvMin[0]) / (uvMax[0] - uvMin[0]), fv = (v - uvMin[1]) / (uvMax[1] - uvMin[1]);
    if (wrap) fu -= std::floor(fu), fv -= std::floor(fv);
    const double x = fu * w - 0.5, y = (1.0 - fv) * h - 0.5;
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double ax = x - x0, ay = y - y0;
    auto texel = [&](int xi, int yi) {
        if (wrap) {
            xi = ((xi % w) + w) % w;
            yi = ((yi % h) + h) % h;
        } else {
            xi = std::clamp(xi, 0, w - 1);
            yi = std::clamp(yi, 0, h - 1);
        }
        return static_cast<double>(luminance.at(xi, yi));
    };
    return (1 - ay) * ((1 - ax) * texel(x0, y0) + ax * texel(x0 + 1, y0)) +
           ay * ((1 - ax) * texel(x0, y0 + 1) + ax * texel(x0 + 1, y0 + 1));
}

ModelTexture modelTexture(const image::ImageF& rgb, std::array<float, 2> uvMin, std::array<float, 2> uvMax) {
    ModelTexture t;
    t.uvMin = uvMin;
    t.uvMax = uvMax;
    t.luminance = image::ImageF(rgb.width(), rgb.height(), 1);
    const int c = rgb.channels();
    for (int y = 0; y < rgb.height(); ++y)
        for (int x = 0; x < rgb.width(); ++x)
            t.luminance.at(x, y) =
                c >= 3 ? 0.2126f * rgb.at(x, y, 0) + 0.7152f * rgb.at(x, y, 1) + 0.0722f * rgb.at(x, y, 2)
                       : rgb.at(x, y, 0);
    return t;
}

namespace {

// The interpolated vertex normal of triangle t at barycentrics bs, in the
// camera's axes (R: world to camera), unit. (Plain arithmetic: these run per
// sample, and Eigen's 3-vectors were a fifth of a registration's time in the
// sanitized build, where they are not inlined.)
frames::Vec3d cameraNormal(const mesh::Mesh& mesh, std::int32_t t, const double (&bs)[3], const Mat3& R) {
    double nw[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) {
        const auto& nn = mesh.normals[mesh.indices[3 * static_cast<std::size_t>(t) + k]];
        for (int c = 0; c < 3; ++c) nw[c] += bs[k] * nn[c];
    }
    const double* r = R.data();  // column-major
    const double n[3] = {r[0] * nw[0] + r[3] * nw[1] + r[6] * nw[2], r[1] * nw[0] + r[4] * nw[1] + r[7] * nw[2],
                         r[2] * nw[0] + r[5] * nw[1] + r[8] * nw[2]};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    return {n[0] / len, n[1] / len, n[2] / len};
}

double dot3(const frames::Vec3d& a, const Eigen::Vector3d& b) {
    const double* v = b.data();
    return a[0] * v[0] + a[1] * v[1] + a[2] * v[2];
}

// What the model shows at one rasterised sample: the lamp (or the fitted
// rho delta) on the surface point P (camera space) of triangle t at
// barycentrics bs, times `albedo`. `lit`: the point is lit (not back-facing).
double shadeSample(const mesh::Mesh& mesh, std::int32_t t, const double (&bs)[3], const Eigen::Vector3d& P,
                   const Mat3& R, const frames::Vec3d& L, const frames::LampProfile& lamp,
                   const shading::BrdfParams* brdf, double albedo, bool& lit) {
    const frames::Vec3d nc = cameraNormal(mesh, t, bs, R);
    const double* p = P.data();
    lit = false;
    if (brdf) {
        // The fitted model: lit from the viewpoint.
        const double z = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), gamma = -dot3(nc, P) / z;
        if (gamma <= 0) return 0.0;
        lit = true;
        return albedo * fit::fittedShading(*brdf, gamma, z);
    }
    // The walls' back-scatter: the renderer's ambient, k_a x the lamp at 10 mm.
    double sum = albedo * lamp.ambient / 100.0;
    const double l[3] = {L[0] - p[0], L[1] - p[1], L[2] - p[2]};
    const double d = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    const double cosine = (nc[0] * l[0] + nc[1] * l[1] + nc[2] * l[2]) / d;
    // The lamp's profile: theta from its axis (the optical axis).
    const double profile = lamp.spread == 0 ? 1.0 : std::exp(-lamp.spread * (1.0 + l[2] / d));
    if (cosine > 0) {
        sum += albedo * cosine * profile / (d * d + lamp.radiusMm * lamp.radiusMm);
        lit = true;
    }
    return sum;
}

// The albedo at a rasterised sample: the per-vertex map, the atlas through
// the mesh's UVs, or 1.
double albedoAt(const mesh::Mesh& mesh, const ModelTexture* texture, std::int32_t t, const double (&bs)[3]) {
    if (!texture) return 1.0;
    const std::size_t base = 3 * static_cast<std::size_t>(t);
    if (!texture->perVertex.empty()) {
        double a = 0;
        for (int k = 0; k < 3; ++k) a += bs[k] * texture->perVertex[mesh.indices[base + k]];
        return a;
    }
    if (!mesh.hasUvs()) return 1.0;
    double u = 0, v = 0;
    for (int k = 0; k < 3; ++k) {
        const auto& uv = mesh.uvs[mesh.indices[base + k]];
        u += bs[k] * uv[0], v += bs[k] * uv[1];
    }
    return texture->at(u, v);
}

frames::Intrinsics scaled(const frames::Intrinsics& K, int ss) {
    frames::Intrinsics Ks = K;
    Ks.width = K.width * ss;
    Ks.height = K.height * ss;
    Ks.fx = K.fx * ss;
    Ks.fy = K.fy * ss;
    Ks.cx = (K.cx + 0.5) * ss - 0.5;
    Ks.cy = (K.cy + 0.5) * ss - 0.5;
    return Ks;
}

}  // namespace

ModelView renderModel(const mesh::Mesh& mesh, const frames::Intrinsics& K, const frames::Mat4& cameraToWorld,
                      const frames::Vec3d& L, int threads, int supersample, const frames::LampProfile& lamp,
                      const shading::BrdfParams* brdf, const ModelTexture* texture) {
    if (texture && !texture->perVertex.empty() && texture->perVertex.size() != mesh.vertexCount())
        throw InputError("model texture", "registration", "has an albedo for a different number of vertices");
    // Rendered at `supersample` x the resolution and box-filtered, as the
    // video's pixels integrate the scene: without it the model is point-
    // sampled, and the comparison favours a pose that aliases alike.
    const int ss = std::max(1, supersample);
    const frames::Intrinsics Ks = scaled(K, ss);
    const frames::Mat4 W = frames::invertRigid(cameraToWorld);
    const raster::GBuffer g = raster::rasterize(mesh, Ks, W, 0.5, threads);
    ModelView v;
    v.shading = image::ImageF(K.width, K.height, 1);
    v.depth = image::ImageF(K.width, K.height, 1);
    v.seen.assign(static_cast<std::size_t>(K.width) * K.height, 0);
    const Mat3 R = rotationOf(W);
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            double sum = 0, depth = 0;
            int hits = 0, lit = 0;
            for (int sy = 0; sy < ss; ++sy)
                for (int sx = 0; sx < ss; ++sx) {
                    const int X = x * ss + sx, Y = y * ss + sy;
                    const std::size_t i = static_cast<std::size_t>(Y) * Ks.width + X;
                    const std::int32_t t = g.triangle[i];
                    if (t < 0) continue;
                    ++hits;
                    const double z = g.depth[i];
                    depth += z;
                    const Eigen::Vector3d P((X - Ks.cx) / Ks.fx * z, (Y - Ks.cy) / Ks.fy * z, z);
                    const double b1 = g.b1[i], b2 = g.b2[i];
                    const double bs[3] = {1 - b1 - b2, b1, b2};
                    bool isLit = false;
                    sum += shadeSample(mesh, t, bs, P, R, L, lamp, brdf, albedoAt(mesh, texture, t, bs), isLit);
                    lit += isLit;
                }
            const std::size_t o = static_cast<std::size_t>(y) * K.width + x;
            v.shading.data()[o] = static_cast<float>(sum / (ss * ss));
            v.depth.data()[o] = hits ? static_cast<float>(depth / hits) : std::numeric_limits<float>::infinity();
            // Seen: every sub-sample hits a lit surface (a pixel on an
            // occluding contour or the mesh's edge mixes two surfaces).
            v.seen[o] = lit == ss * ss ? 1 : 0;
        }
    return v;
}

std::size_t AlbedoMap::add(const mesh::Mesh& fullMesh, const VideoFrame& frame, const frames::Mat4& cameraToWorld,
                           const RegisterOptions& o) {
    if (fullMesh.vertexCount() != sum_.size())
        throw InputError("albedo map", "registration", "was made for a mesh with a different number of vertices");
    if (!fullMesh.hasNormals()) throw InputError("mesh", "albedo map", "has no normals");
    if (frame.levels.empty()) return 0;
    const VideoFrame::Level& level = frame.levels.back();
    const frames::Intrinsics& K = level.K;
    std::vector<std::uint32_t> kept;
    const mesh::Mesh mesh =
        submesh(fullMesh, trianglesNear(fullMesh, frames::cameraCentre(cameraToWorld), o.farMm), &kept);
    const frames::Mat4 W = frames::invertRigid(cameraToWorld);
    const raster::GBuffer g = raster::rasterize(mesh, K, W, 0.5, 1);
    const Mat3 R = rotationOf(W);
    const std::size_t n = static_cast<std::size_t>(K.width) * K.height;
    // The dark lumen carries noise, not albedo: the pq estimator's threshold.
    std::vector<float> inside;
    for (std::size_t i = 0; i < n; ++i)
        if (level.valid[i]) inside.push_back(level.luminance.data()[i]);
    const double dark = level.pqOptions.darkFraction * percentile(inside, 0.99);
    struct Observation {
        std::int32_t triangle;
        double b[3];
        double ratio, weight;
    };
    std::vector<Observation> obs;
    for (int y = 0; y < K.height; ++y)
        for (int x = 0; x < K.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * K.width + x;
            const std::int32_t t = g.triangle[i];
            const double e = level.luminance.data()[i];
            if (t < 0 || !level.valid[i] || e <= dark) continue;
            const double z = g.depth[i];
            const Eigen::Vector3d P((x - K.cx) / K.fx * z, (y - K.cy) / K.fy * z, z);
            const double b1 = g.b1[i], b2 = g.b2[i];
            const double bs[3] = {1 - b1 - b2, b1, b2};
            bool lit = false;
            const double shade =
                shadeSample(mesh, t, bs, P, R, o.lightOffset, o.lamp, o.brdf ? &*o.brdf : nullptr, 1.0, lit);
            if (!lit || shade <= 0) continue;
            const double d = P.norm(), gamma = -dot3(cameraNormal(mesh, t, bs, R), P) / d;
            if (gamma <= 0.1) continue;  // grazing: the normal's error dominates the shading
            obs.push_back({t, {bs[0], bs[1], bs[2]}, e / shade, gamma * gamma / (d * d)});
        }
    if (obs.size() < 50) return 0;
    // The frame's exposure against what the map holds.
    std::vector<float> toMap, raw;
    for (const Observation& ob : obs) {
        raw.push_back(static_cast<float>(ob.ratio));
        double a = 0;
        bool known = true;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = kept[mesh.indices[3 * static_cast<std::size_t>(ob.triangle) + k]];
            if (weight_[v] <= 0)
                known = false;
            else
                a += ob.b[k] * sum_[v] / weight_[v];
        }
        if (known && a > 0) toMap.push_back(static_cast<float>(ob.ratio / a));
    }
    double gain = 0;
    if (toMap.size() >= 50)
        gain = percentile(toMap, 0.5);
    else {
        double seen = 0, mean = 0;
        for (std::size_t v = 0; v < sum_.size(); ++v)
            if (weight_[v] > 0) mean += sum_[v] / weight_[v], ++seen;
        gain = percentile(raw, 0.5) / (seen > 0 ? mean / seen : 1.0);
    }
    if (!(gain > 0)) return 0;
    std::size_t used = 0;
    for (const Observation& ob : obs) {
        const double a = ob.ratio / gain;
        if (a > 4 || a < 0.1) continue;  // a glint's fringe, a shadow the model lacks
        ++used;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = kept[mesh.indices[3 * static_cast<std::size_t>(ob.triangle) + k]];
            sum_[v] += ob.weight * ob.b[k] * a;
            weight_[v] += ob.weight * ob.b[k];
        }
    }
    ++frames_;
    return used;
}

std::shared_ptr<const ModelTexture> AlbedoMap::texture() const {
    auto t = std::make_shared<ModelTexture>();
    t->perVertex.resize(sum_.size());
    double mean = 0, seen = 0;
    for (std::size_t v = 0; v < sum_.size(); ++v)
        if (weight_[v] > 0) mean += sum_[v] / weight_[v], ++seen;
    mean = seen > 0 ? mean / seen : 1.0;
    for (std::size_t v = 0; v < sum_.size(); ++v)
        t->perVertex[v] = static_cast<float>(weight_[v] > 0 ? sum_[v] / weight_[v] : mean);
    return t;
}

double AlbedoMap::seenFraction() const noexcept {
    if (weight_.empty()) return 0;
    return static_cast<double>(std::count_if(weight_.begin(), weight_.end(), [](double w) { return w > 0; })) /
           static_cast<double>(weight_.size());
}

PqField pqFromModel(const ModelView& view, const frames::Intrinsics& K, const PqOptions& o,
                    const std::vector<std::uint8_t>* usable) {
    const std::size_t n = static_cast<std::size_t>(K.width) * K.height;
    std::vector<std::uint8_t> use(n);
    for (std::size_t i = 0; i < n; ++i)
        use[i] = view.seen[i] && view.shading.data()[i] > 0 && (!usable || (*usable)[i]);
    const image::ImageF filtered = openClose(view.shading, use, o.albedoFilterPx);
    return estimate(filtered, std::move(use), K, o, 0, true);
}

double pqSimilarity(const PqField& video, const PqField& model) {
    double sw = 0, sc = 0;
    for (std::size_t i = 0; i < video.weight.size(); ++i) {
        const double w = video.weight[i];
        if (w <= 0) continue;
        sw += w;
        if (model.weight[i] <= 0) continue;
        const auto &a = video.normal[i], &b = model.normal[i];
        sc += w *
              (static_cast<double>(a[0]) * b[0] + static_cast<double>(a[1]) * b[1] + static_cast<double>(a[2]) * b[2]);
    }
    return sw > 0 ? sc / sw : 0;
}

double normalisedCrossCorrelation(const image::ImageF& a, const image::ImageF& b,
                                  const std::vector<std::uint8_t>& valid) {
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0, n = 0;
    for (std::size_t i = 0; i < valid.size(); ++i) {
        if (!valid[i]) continue;
        const double x = a.data()[i], y = b.data()[i];
        sa += x, sb += y, saa += x * x, sbb += y * y, sab += x * y, ++n;
    }
    if (n < 2) return 0;
    const double cov = sab / n - sa * sb / (n * n);
    const double va = saa / n - sa * sa / (n * n), vb = sbb / n - sb * sb / (n * n);
    return va > 0 && vb > 0 ? cov / std::sqrt(va * vb) : 0;
}

VideoFrame prepareFrame(const image::ImageF& linear, const image::Image8* saturated, const frames::Intrinsics& K,
                        const RegisterOptions& o) {
    const int W = linear.width(), H = linear.height();
    // Luminance (Rec. 709 weights) and the scope's field of view.
    std::vector<float> lum(static_cast<std::size_t>(W) * H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const int c = linear.channels();
            const float r = linear.at(x, y, 0), g = linear.at(x, y, c > 1 ? 1 : 0), b = linear.at(x, y, c > 2 ? 2 : 0);
            lum[static_cast<std::size_t>(y) * W + x] = 0.2126f * r + 0.7152f * g + 0.0722f * b;
        }
    const std::vector<std::uint8_t> outside = fit::outsideFieldOfView(linear);

    VideoFrame f;
    for (int width : o.levels) {
        width = std::min(width, W);
        if (!f.levels.empty() && f.levels.back().K.width == width) continue;
        const double s = static_cast<double>(width) / W;
        VideoFrame::Level l;
        l.K.width = width;
        l.K.height = std::max(1, static_cast<int>(std::lround(H * s)));
        const double sy = static_cast<double>(l.K.height) / H;
        l.K.fx = K.fx * s;
        l.K.fy = K.fy * sy;
        l.K.cx = (K.cx + 0.5) * s - 0.5;
        l.K.cy = (K.cy + 0.5) * sy - 0.5;
        l.luminance = image::ImageF(l.K.width, l.K.height, 1);
        l.valid.assign(static_cast<std::size_t>(l.K.width) * l.K.height, 0);
        const int taps = std::clamp(static_cast<int>(std::ceil(1 / s)), 1, 4);
        for (int y = 0; y < l.K.height; ++y)
            for (int x = 0; x < l.K.width; ++x) {
                double sum = 0;
                bool ok = true;
                for (int j = 0; ok && j < taps; ++j)
                    for (int i = 0; ok && i < taps; ++i) {
                        const double u = x + (i + 0.5) / taps - 0.5, v = y + (j + 0.5) / taps - 0.5;
                        const auto px = frames::project(K, (u - l.K.cx) / l.K.fx, (v - l.K.cy) / l.K.fy);
                        const double fx = px[0], fy = px[1];
                        if (!(fx >= 0 && fy >= 0 && fx <= W - 1 && fy <= H - 1)) {
                            ok = false;
                            break;
                        }
                        const int x0 = std::min(W - 2, static_cast<int>(fx)),
                                  y0 = std::min(H - 2, static_cast<int>(fy));
                        const double ax = fx - x0, ay = fy - y0;
                        double acc = 0;
                        for (int dy = 0; dy < 2; ++dy)
                            for (int dx = 0; dx < 2; ++dx) {
                                const std::size_t k = static_cast<std::size_t>(y0 + dy) * W + x0 + dx;
                                const double wgt = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
                                if (wgt <= 0) continue;
                                if (outside[k] || (saturated && saturated->data()[k])) ok = false;
                                acc += wgt * lum[k];
                            }
                        sum += acc;
                    }
                const std::size_t i = static_cast<std::size_t>(y) * l.K.width + x;
                l.luminance.data()[i] = ok ? static_cast<float>(sum / (taps * taps)) : 0.f;
                l.valid[i] = ok && l.luminance.data()[i] < o.saturation;
            }
        // The albedo filter's radius is given in the frame's pixels.
        l.pqOptions = o.pq;
        l.pqOptions.albedoFilterPx = static_cast<int>(std::lround(o.albedoFilterPx * s));
        if (o.method == RegistrationMethod::PqSpace) l.pq = pqFromShading(l.luminance, l.K, l.pqOptions, &l.valid);
        f.levels.push_back(std::move(l));
    }
    return f;
}

std::vector<std::uint32_t> trianglesNear(const mesh::Mesh& m, const frames::Vec3d& c, double radius) {
    std::vector<std::uint32_t> out;
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        double best = std::numeric_limits<double>::infinity();
        for (int k = 0; k < 3; ++k) {
            const auto& p = m.positions[m.indices[3 * t + k]];
            const double dx = p[0] - c[0], dy = p[1] - c[1], dz = p[2] - c[2];
            best = std::min(best, dx * dx + dy * dy + dz * dz);
        }
        if (best <= radius * radius) out.push_back(static_cast<std::uint32_t>(t));
    }
    return out;
}

namespace {

// The area, in pixels, over which the weighted residuals r = sqrt(w) d of
// a level are correlated: 1 (the lag 0) plus the sum of their normalised
// autocorrelation over the other lags within `radius` pixels (those that
// at least a quarter of the pixels pair across), at least 1. Independent
// residuals give 1; the pq estimator's smoothing, a model's blur or an
// albedo the model lacks give more, and about one residual in that many is
// independent. Beyond 8 pixels of radius the lags are taken on a coarser
// grid, each standing for the step^2 lags around it, so that the cost stays
// at 17 x 17 lags on any level (finer levels than the default's 80 pixels).
double correlationArea(const std::vector<double>& d, int b, const std::vector<double>& w,
                       const std::vector<std::size_t>& pixels, int width, int height, int radius) {
    const std::size_t n = static_cast<std::size_t>(width) * height;
    std::vector<double> r(n * static_cast<std::size_t>(b), 0.0);
    std::vector<std::uint8_t> used(n, 0);
    std::size_t count = 0;
    for (std::size_t k = 0; k < pixels.size(); ++k) {
        if (!(w[k] > 0)) continue;
        const double s = std::sqrt(w[k]);
        for (int j = 0; j < b; ++j) r[pixels[k] * b + j] = s * d[k * b + j];
        used[pixels[k]] = 1;
        ++count;
    }
    double c0 = 0;
    for (std::size_t i = 0; i < n * b; ++i) c0 += r[i] * r[i];
    if (count == 0 || !(c0 > 0)) return 1.0;
    c0 /= static_cast<double>(count);
    const int step = (radius + 7) / 8;
    const int reach = radius / step * step;
    double area = 1;
    for (int dy = -reach; dy <= reach; dy += step)
        for (int dx = -reach; dx <= reach; dx += step) {
            if (dx == 0 && dy == 0) continue;
            double c = 0;
            std::size_t pairs = 0;
            for (int y = std::max(0, -dy); y < std::min(height, height - dy); ++y)
                for (int x = std::max(0, -dx); x < std::min(width, width - dx); ++x) {
                    const std::size_t i = static_cast<std::size_t>(y) * width + x;
                    const std::size_t k = static_cast<std::size_t>(y + dy) * width + (x + dx);
                    if (!used[i] || !used[k]) continue;
                    for (int j = 0; j < b; ++j) c += r[i * b + j] * r[k * b + j];
                    ++pairs;
                }
            if (pairs * 4 < count) continue;
            area += static_cast<double>(step * step) * c / static_cast<double>(pairs) / c0;
        }
    return std::max(1.0, area);
}

// The pose's standard deviations (FrameRegistration::poseSd) from the
// data's Gauss-Newton matrix A (parameters in units of the steps h), the
// residuals' variance s2 per degree of freedom, and the area kappa over
// which they are correlated (correlationArea): of n residuals about n /
// kappa are independent, so the covariance is kappa s2 A^-1. The marginal
// deviations (the inverse's diagonal), so an axis traded against another (a
// lateral shift against the viewing direction) shows as uncertain on both.
std::array<double, 6> poseDeviation(const Eigen::Matrix<double, 6, 6>& A, double s2,
                                    const Eigen::Matrix<double, 6, 1>& h, double kappa) {
    std::array<double, 6> sd;
    sd.fill(std::numeric_limits<double>::infinity());
    // A rank-deficient A (an axis no pixel responds to): that axis, and any
    // traded against it, is undetermined.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(A);
    if (eig.info() != Eigen::Success) return sd;
    const Eigen::Matrix<double, 6, 1> lambda = eig.eigenvalues();
    const double top = lambda.maxCoeff();
    if (!(top > 0)) return sd;
    Eigen::Matrix<double, 6, 6> inverse = Eigen::Matrix<double, 6, 6>::Zero();
    for (int i = 0; i < 6; ++i) {
        if (!(lambda[i] > 1e-12 * top)) continue;
        inverse += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose() / lambda[i];
    }
    for (int a = 0; a < 6; ++a) {
        bool determined = true;
        for (int i = 0; i < 6; ++i)
            if (!(lambda[i] > 1e-12 * top) && std::abs(eig.eigenvectors()(a, i)) > 1e-6) determined = false;
        if (!determined) continue;
        const double v = std::sqrt(std::max(0.0, inverse(a, a) * s2 * kappa)) * h[a];
        sd[static_cast<std::size_t>(a)] = a < 3 ? v : v * 180 / M_PI;
    }
    return sd;
}

// registerFrame's coarse-to-fine optimisation, from `firstLevel` on.
FrameRegistration registerLevels(const mesh::Mesh& mesh, const RegisterOptions& o, const VideoFrame& frame,
                                 const frames::Mat4& initial, std::size_t firstLevel, Clock::time_point start) {
    FrameRegistration r;
    r.cameraToWorld = initial;
    const int finest = frame.levels.back().K.width;
    bool atMinimum = false;
    double lastStep = 0;  // the finest level's last accepted step, in finite-difference steps
    for (std::size_t li = firstLevel; li < frame.levels.size(); ++li) {
        const VideoFrame::Level& level = frame.levels[li];
        Objective obj(mesh, level, o, r);
        if (obj.pixels.size() < 50) {
            r.similarity = 0;
            r.converged = false;
            r.optimiserSeconds = std::max(0.0, secondsSince(start) - r.renderSeconds - r.similaritySeconds);
            return r;
        }
        // Parameters in units of the finite-difference steps (scaled to the
        // level: a coarse pixel sees a coarser change), so that the six
        // columns of the Jacobian are comparable.
        const double scale = static_cast<double>(finest) / level.K.width;
        const double ht = o.stepMm * scale, hw = o.stepDeg * scale * M_PI / 180;
        const frames::Mat4 base = r.cameraToWorld;
        auto poseAt = [&](const Eigen::Matrix<double, 6, 1>& x) {
            return perturbPose(base, {x[0] * ht, x[1] * ht, x[2] * ht}, {x[3] * hw, x[4] * hw, x[5] * hw});
        };
        Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
        // The motion prior: residuals (d0 + h x) / sigma per axis, d0 the
        // level's starting pose relative to the frame's (mm, radians, in the
        // starting camera's axes), h the step, to first order in x.
        Eigen::Matrix<double, 6, 1> d0 = Eigen::Matrix<double, 6, 1>::Zero(), h, sigma;
        double priorWeight = 0;
        Eigen::Matrix<double, 6, 1> axisWeight;  // per axis, relative to priorWeight
        if (o.motionPrior > 0 || o.rollPrior > 0) {
            const Mat3 R0 = rotationOf(initial);
            const Eigen::Vector3d t =
                R0.transpose() *
                Eigen::Vector3d(base[0][3] - initial[0][3], base[1][3] - initial[1][3], base[2][3] - initial[2][3]);
            const Eigen::AngleAxisd aa(R0.transpose() * rotationOf(base));
            const Eigen::Vector3d w = aa.axis() * aa.angle();
            d0 << t[0], t[1], t[2], w[0], w[1], w[2];
            // In units of the data cost of a mean squared residual of 1: pq's
            // cost sums over the pixels' weights, the intensity cost is a mean.
            double total = 1;
            if (o.method == RegistrationMethod::PqSpace) {
                total = 0;
                for (std::size_t k = 0; k < obj.pixels.size(); ++k) total += obj.weight(k);
            }
            priorWeight = total;
        }
        axisWeight.setConstant(o.motionPrior);
        axisWeight[5] += o.rollPrior;
        h << ht, ht, ht, hw, hw, hw;
        sigma << o.priorMm, o.priorMm, o.priorMm, o.priorDeg * M_PI / 180, o.priorDeg * M_PI / 180,
            o.priorDeg * M_PI / 180;
        auto priorCost = [&](const Eigen::Matrix<double, 6, 1>& xx) {
            if (priorWeight <= 0) return 0.0;
            return priorWeight * axisWeight.dot((d0 + h.cwiseProduct(xx)).cwiseQuotient(sigma).cwiseAbs2());
        };
        double sim = 0;
        std::vector<std::uint8_t> seen;
        std::vector<double> d = obj.differences(poseAt(x), &sim, &seen);
        double cost = robustCost(obj, d) + priorCost(x);
        double lambda = 1e-3;
        atMinimum = false;
        lastStep = 0;
        const int b = obj.block();
        // The finest level's data-only normal equations at the last
        // iteration, and the residuals there: the pose's uncertainty.
        const bool finestLevel = li + 1 == frame.levels.size();
        Eigen::Matrix<double, 6, 6> dataA = Eigen::Matrix<double, 6, 6>::Zero();
        double residual2 = 0, residualDof = 0;
        for (int it = 0; it < o.maxIterations; ++it) {
            ++r.iterations;
            // IRLS weights of the Cauchy loss at the current pose.
            std::vector<double> wrow(obj.pixels.size());
            for (std::size_t k = 0; k < obj.pixels.size(); ++k) {
                double e2 = 0;
                for (int j = 0; j < b; ++j) e2 += d[b * k + j] * d[b * k + j];
                wrow[k] = o.method == RegistrationMethod::PqSpace ? obj.weight(k) / (1 + e2 / obj.cauchy2) : 1.0;
            }
            Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
            Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
            std::vector<std::vector<double>> cols(6);
            // Central differences, half a step either side: 12 renders, run
            // side by side (each single-threaded).
            std::vector<std::vector<double>> ds(12);
            std::vector<std::vector<std::uint8_t>> seens(12);
            std::vector<FrameRegistration> timing(12);
            tbb::task_arena arena(resolveThreads(o.threads));
            arena.execute([&] {
                tbb::parallel_for(0, 12, [&](int t) {
                    Eigen::Matrix<double, 6, 1> xt = x;
                    xt[t / 2] += t % 2 == 0 ? 0.5 : -0.5;
                    Objective local = obj;  // its own timing counters
                    local.stats = &timing[static_cast<std::size_t>(t)];
                    ds[static_cast<std::size_t>(t)] =
                        local.differences(poseAt(xt), nullptr, &seens[static_cast<std::size_t>(t)]);
                });
            });
            for (const FrameRegistration& t : timing) {
                r.renderSeconds += t.renderSeconds / resolveThreads(o.threads);
                r.similaritySeconds += t.similaritySeconds / resolveThreads(o.threads);
                r.evaluations += t.evaluations;
            }
            for (int j = 0; j < 6; ++j) {
                std::vector<double>& dp = ds[static_cast<std::size_t>(2 * j)];
                const std::vector<double>& dm = ds[static_cast<std::size_t>(2 * j + 1)];
                const auto& seenP = seens[static_cast<std::size_t>(2 * j)];
                const auto& seenM = seens[static_cast<std::size_t>(2 * j + 1)];
                // A pixel that enters or leaves the model's support between the
                // two poses jumps: it carries no derivative (direct alignment's
                // usual rule), and would swamp the smooth part of the Jacobian.
                for (std::size_t k = 0; k < dp.size(); ++k)
                    dp[k] = seen[k / b] && seenP[k / b] && seenM[k / b] ? dp[k] - dm[k] : 0.0;
                cols[j] = std::move(dp);
            }
            for (std::size_t k = 0; k < d.size(); ++k) {
                const double wk = wrow[k / b];
                for (int a = 0; a < 6; ++a) {
                    g[a] += wk * cols[a][k] * d[k];
                    for (int c = a; c < 6; ++c) A(a, c) += wk * cols[a][k] * cols[c][k];
                }
            }
            for (int a = 0; a < 6; ++a)
                for (int c = 0; c < a; ++c) A(a, c) = A(c, a);
            if (finestLevel) {
                dataA = A;
                residual2 = residualDof = 0;
                // Degrees of freedom per pixel: a unit normal's difference has
                // two to first order, an intensity one.
                const double dofPerPixel = o.method == RegistrationMethod::PqSpace ? 2 : 1;
                for (std::size_t k = 0; k < obj.pixels.size(); ++k) {
                    if (!(wrow[k] > 0)) continue;
                    double e2 = 0;
                    for (int j = 0; j < b; ++j) e2 += d[b * k + j] * d[b * k + j];
                    residual2 += wrow[k] * e2;
                    residualDof += dofPerPixel;
                }
            }
            if (priorWeight > 0)
                for (int a = 0; a < 6; ++a) {
                    const double ja = h[a] / sigma[a];  // d residual / d x
                    A(a, a) += priorWeight * axisWeight[a] * ja * ja;
                    g[a] += priorWeight * axisWeight[a] * ja * (d0[a] + h[a] * x[a]) / sigma[a];
                }
            bool improved = false;
            Eigen::Matrix<double, 6, 1> step = Eigen::Matrix<double, 6, 1>::Zero();
            for (int tries = 0; tries < 6 && !improved; ++tries) {
                Eigen::Matrix<double, 6, 6> M = A;
                for (int a = 0; a < 6; ++a) M(a, a) += lambda * (A(a, a) + 1e-9);
                step = M.ldlt().solve(-g);
                if (!step.allFinite()) break;
                // A trust region of 20 steps (a few mm, a few degrees) per iteration.
                const double len = step.norm();
                if (len > 20) step *= 20 / len;
                double s2 = 0;
                std::vector<std::uint8_t> seen2;
                std::vector<double> d2 = obj.differences(poseAt(x + step), &s2, &seen2);
                const double c2 = robustCost(obj, d2) + priorCost(x + step);
                if (c2 < cost) {
                    x += step, d = std::move(d2), cost = c2, sim = s2, seen = std::move(seen2);
                    lambda = std::max(1e-6, lambda / 3);
                    improved = true;
                    // The linearisation is local (the normal field moves by
                    // pixels per millimetre): keep going along the direction
                    // while the cost keeps falling.
                    for (int ext = 0; ext < 4; ++ext) {
                        double s3 = 0;
                        std::vector<std::uint8_t> seen3;
                        std::vector<double> d3 = obj.differences(poseAt(x + step), &s3, &seen3);
                        const double c3 = robustCost(obj, d3) + priorCost(x + step);
                        if (!(c3 < cost)) break;
                        x += step, d = std::move(d3), cost = c3, sim = s3, seen = std::move(seen3);
                    }
                } else {
                    lambda *= 5;
                }
            }
            lastStep = improved ? step.norm() : 0.0;
            if (!improved || step.norm() < 0.05) {
                atMinimum = true;
                break;
            }
        }
        r.cameraToWorld = poseAt(x);
        r.similarity = sim;
        if (finestLevel && residualDof > 6) {
            // The residuals' correlation at the estimate (once: it changes
            // little over the last steps), out to a tenth of the view (8
            // pixels at the default 80 across).
            std::vector<double> wEnd(obj.pixels.size());
            for (std::size_t k = 0; k < obj.pixels.size(); ++k) {
                double e2 = 0;
                for (int j = 0; j < b; ++j) e2 += d[b * k + j] * d[b * k + j];
                wEnd[k] = o.method == RegistrationMethod::PqSpace ? obj.weight(k) / (1 + e2 / obj.cauchy2) : 1.0;
            }
            const double kappa = correlationArea(d, b, wEnd, obj.pixels, level.K.width, level.K.height,
                                                 std::max(2, (level.K.width + 5) / 10));
            r.poseSd = poseDeviation(dataA, residual2 / (residualDof - 6), h, kappa);
        }
    }
    // Converged: the optimiser stopped at a minimum, or its last step moved
    // the pose by less than half a finite-difference step (the iteration cap
    // reached while creeping), and the fields agree.
    r.converged = (atMinimum || lastStep < 0.5) &&
                  r.similarity >= (o.method == RegistrationMethod::PqSpace ? o.minSimilarity : o.minCorrelation);
    r.optimiserSeconds = std::max(0.0, secondsSince(start) - r.renderSeconds - r.similaritySeconds);
    return r;
}

// Which of two registrations of a frame to keep: a converged one over a
// flagged one, then the higher similarity.
bool outranks(const FrameRegistration& a, const FrameRegistration& b) noexcept {
    return (a.converged && !b.converged) || (a.converged == b.converged && a.similarity > b.similarity);
}

}  // namespace

FrameRegistration registerFrame(const mesh::Mesh& fullMesh, const VideoFrame& frame, const frames::Mat4& initial,
                                const RegisterOptions& options) {
    const auto start = Clock::now();
    if (frame.levels.empty()) throw InputError("frame", "registration", "has no levels");
    const Neighbourhood near = neighbourhood(fullMesh, frames::cameraCentre(initial), options.farMm, options);
    FrameRegistration r = registerLevels(near.mesh, near.options, frame, initial, 0, start);
    // A coarse level can prefer a pose the finest one does not (a bias of the
    // blurred field: on the category-4 phantom's first frame, 40 pixels
    // across preferred a roll 24 degrees off that scored 0.90 at 80 against
    // 0.94 where the finest level alone went, until session 25's normals). When the coarse levels moved
    // the pose further than `recheckMm` / `recheckDeg`, the finest level is
    // also run from the start, and the better of the two kept (with
    // options.recheck: registerInitial's refinement).
    const std::size_t last = frame.levels.size() - 1;
    const PoseError moved = poseError(r.cameraToWorld, initial);
    if (options.recheck && last > 0 && (moved.position > options.recheckMm || moved.degrees > options.recheckDeg)) {
        FrameRegistration f = registerLevels(near.mesh, near.options, frame, initial, last, start);
        f.renderSeconds += r.renderSeconds, f.similaritySeconds += r.similaritySeconds;
        f.iterations += r.iterations, f.evaluations += r.evaluations;
        r.renderSeconds = f.renderSeconds, r.similaritySeconds = f.similaritySeconds;
        r.iterations = f.iterations, r.evaluations = f.evaluations;
        if ((f.converged && !r.converged) || (f.converged == r.converged && f.similarity > r.similarity)) r = f;
        r.optimiserSeconds = std::max(0.0, secondsSince(start) - r.renderSeconds - r.similaritySeconds);
    }
    // The view's depth at the estimate: down a lumen its farthest part lies
    // many times beyond the median wall, facing a wall nothing does.
    {
        const VideoFrame::Level& fin = frame.levels.back();
        const auto t0 = Clock::now();
        const ModelView v = renderModel(near.mesh, fin.K, r.cameraToWorld, options.lightOffset, 1, 1, options.lamp);
        r.renderSeconds += secondsSince(t0);
        ++r.evaluations;
        std::vector<float> z;
        for (std::size_t i = 0; i < fin.valid.size(); ++i)
            if (fin.valid[i]) {
                const float d = v.depth.data()[i];
                z.push_back(std::isfinite(d) ? d : static_cast<float>(options.farMm));  // beyond the neighbourhood
            }
        if (z.size() >= 50) r.depthRange = percentile(z, 0.99) / std::max(1e-6, percentile(z, 0.5));
    }
    if (std::isfinite(r.depthRange) && r.depthRange < options.minDepthRange) r.converged = false, r.noLumen = true;
    return r;
}

FrameRegistration registerTracked(const mesh::Mesh& mesh, const VideoFrame& frame, Tracker& tracker,
                                  const RegisterOptions& o, AlbedoMap* map) {
    const RegisterOptions options = tracker.options(o);
    const bool mapped = map && map->frames() > 0;
    // The map's step: intensity against the model carrying the albedo, free.
    RegisterOptions byMap = o;
    if (mapped) {
        byMap.method = RegistrationMethod::Intensity;
        byMap.texture = map->texture();
        byMap.motionPrior = byMap.rollPrior = 0;
        // The wall's albedo is the evidence a frame with no lumen in view
        // has left: the map's step is not flagged for it.
        byMap.minDepthRange = 0;
    }
    FrameRegistration best;
    bool have = false;
    // The map's step where it converged: the estimate kept for a frame the
    // method itself does not converge on.
    std::optional<FrameRegistration> byMapBest;
    double render = 0, similarity = 0, optimiser = 0;
    int iterations = 0, evaluations = 0;
    for (const frames::Mat4& trackStart : tracker.starts()) {
        frames::Mat4 start = trackStart;
        RegisterOptions method = options;
        if (mapped) {
            const FrameRegistration m = registerFrame(mesh, frame, trackStart, byMap);
            render += m.renderSeconds, similarity += m.similaritySeconds, optimiser += m.optimiserSeconds;
            iterations += m.iterations, evaluations += m.evaluations;
            const PoseError reach = poseError(m.cameraToWorld, trackStart);
            const bool withinReach = (o.mapReachMm <= 0 || reach.position <= o.mapReachMm) &&
                                     (o.mapReachDegrees <= 0 || reach.degrees <= o.mapReachDegrees);
            if (m.converged && withinReach) {
                start = m.cameraToWorld;
                method.motionPrior = o.albedoPrior;
                if (!byMapBest || m.similarity > byMapBest->similarity) byMapBest = m;
            }
        }
        FrameRegistration r = registerFrame(mesh, frame, start, method);
        render += r.renderSeconds, similarity += r.similaritySeconds, optimiser += r.optimiserSeconds;
        iterations += r.iterations, evaluations += r.evaluations;
        if (!have || outranks(r, best)) best = r, have = true;
    }
    if (best.converged && byMapBest) {
        const PoseError apart = poseError(best.cameraToWorld, byMapBest->cameraToWorld);
        if ((o.mapAgreementMm > 0 && apart.position > o.mapAgreementMm) ||
            (o.mapAgreementDegrees > 0 && apart.degrees > o.mapAgreementDegrees))
            best.converged = false, best.mapDisagreed = true;
    }
    if (!best.converged && byMapBest && o.keepMapPose) {
        // Flagged either way; the estimate is the map's converged pose, with
        // the method's similarity there (an evaluation, no iterations).
        RegisterOptions at = options;
        at.maxIterations = 0;
        at.recheck = false;
        const FrameRegistration s = registerFrame(mesh, frame, byMapBest->cameraToWorld, at);
        render += s.renderSeconds, similarity += s.similaritySeconds, evaluations += s.evaluations;
        best.cameraToWorld = byMapBest->cameraToWorld;
        best.similarity = s.similarity;
        best.poseSd = byMapBest->poseSd;
        best.depthRange = s.depthRange;  // the kept pose's view
        best.noLumen = best.noLumen || s.noLumen;
        best.mapPoseKept = true;
    }
    if (best.noLumen && noLumenSearchCandidates(o) > 0) {
        // Facing the wall, shape fixes the pose weakly and the iterations
        // from the track stop in whatever valley they reach (on the CT
        // airway, poses up to 46 degrees off that the truth outscored): the
        // draws around the track's start, scored and refined as for a first
        // frame, reach the others. The frame stays flagged either way.
        InitialSearch search = o.noLumenSearch;
        search.candidates = noLumenSearchCandidates(o);
        const FrameRegistration w = registerInitial(mesh, frame, tracker.start(), options, search);
        render += w.renderSeconds, similarity += w.similaritySeconds, optimiser += w.optimiserSeconds;
        iterations += w.iterations, evaluations += w.evaluations;
        if (outranks(w, best)) {
            best = w;
            best.searched = true;
        }
    }
    best.renderSeconds = render, best.similaritySeconds = similarity, best.optimiserSeconds = optimiser;
    best.iterations = iterations, best.evaluations = evaluations;
    best.mapConverged = byMapBest.has_value();
    if (byMapBest) best.mapCameraToWorld = byMapBest->cameraToWorld;
    tracker.update(best);
    if (map && paintsAlbedoMap(best, o)) map->add(mesh, frame, best.cameraToWorld, o);
    return best;
}

FrameRegistration registerInitial(const mesh::Mesh& fullMesh, const VideoFrame& frame, const frames::Mat4& initial,
                                  const RegisterOptions& o, const InitialSearch& search) {
    if (frame.levels.empty()) throw InputError("frame", "registration", "has no levels");
    const auto start = Clock::now();
    // The candidates: the given pose first, then draws around it.
    std::vector<frames::Mat4> poses{initial};
    std::mt19937 rng(search.seed);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    std::normal_distribution<double> gauss(0.0, 1.0);
    while (static_cast<int>(poses.size()) < std::max(1, search.candidates)) {
        frames::Vec3d t{uni(rng), uni(rng), uni(rng)};
        if (t[0] * t[0] + t[1] * t[1] + t[2] * t[2] > 1) continue;  // uniform in the ball
        frames::Vec3d w{gauss(rng), gauss(rng), gauss(rng)};
        const double nw = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        const double angle = std::abs(uni(rng)) * search.degrees * M_PI / 180;
        for (int k = 0; k < 3; ++k) t[k] *= search.radiusMm, w[k] *= nw > 0 ? angle / nw : 0.0;
        poses.push_back(perturbPose(initial, t, w));
    }
    // Scored at the coarsest level, side by side.
    const Neighbourhood near = neighbourhood(fullMesh, frames::cameraCentre(initial), o.farMm + search.radiusMm, o);
    const mesh::Mesh& mesh = near.mesh;
    FrameRegistration total;
    std::vector<double> score(poses.size(), -2.0);
    {
        Objective obj(mesh, frame.levels.front(), near.options, total);
        if (obj.pixels.size() >= 50) {
            std::vector<FrameRegistration> timing(poses.size());
            tbb::task_arena arena(resolveThreads(o.threads));
            arena.execute([&] {
                tbb::parallel_for(std::size_t{0}, poses.size(), [&](std::size_t i) {
                    Objective local = obj;
                    local.stats = &timing[i];
                    local.differences(poses[i], &score[i]);
                });
            });
            for (const FrameRegistration& t : timing) {
                total.renderSeconds += t.renderSeconds / resolveThreads(o.threads);
                total.similaritySeconds += t.similaritySeconds / resolveThreads(o.threads);
                total.evaluations += t.evaluations;
            }
        }
    }
    std::vector<std::size_t> order(poses.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return score[a] > score[b]; });
    std::vector<std::size_t> starts{0};
    for (std::size_t i : order) {
        if (static_cast<int>(starts.size()) > std::max(0, search.refine)) break;
        if (i != 0) starts.push_back(i);
    }
    std::vector<FrameRegistration> refined;
    RegisterOptions full = o;
    full.recheck = true;
    // No motion or roll prior: the candidates are draws around a rough pose,
    // not a prediction of where the scope is, and a prior around each would
    // hold its refinement near the draw (the roll prior took the capture
    // test's worst orientation from 1.5 to 2.2 degrees).
    full.motionPrior = full.rollPrior = 0;
    for (std::size_t i : starts) {
        refined.push_back(registerFrame(fullMesh, frame, poses[i], full));
        const FrameRegistration& r = refined.back();
        total.renderSeconds += r.renderSeconds, total.similaritySeconds += r.similaritySeconds;
        total.iterations += r.iterations, total.evaluations += r.evaluations;
    }
    // The best: converged first, then the highest similarity; among results
    // within `tie` of it, the one nearest the given pose (what the user said
    // breaks what the frame cannot: one tracheal ring along scores the same).
    FrameRegistration best = refined.front();
    for (const FrameRegistration& r : refined)
        if (outranks(r, best)) best = r;
    auto distance = [&](const FrameRegistration& r) {
        const PoseError e = poseError(r.cameraToWorld, initial);
        return e.position / std::max(search.radiusMm, 1e-9) + e.degrees / std::max(search.degrees, 1e-9);
    };
    const double bestSimilarity = best.similarity;
    for (const FrameRegistration& r : refined)
        if (r.converged == best.converged && r.similarity >= bestSimilarity - search.tie &&
            distance(r) < distance(best))
            best = r;
    best.renderSeconds = total.renderSeconds, best.similaritySeconds = total.similaritySeconds;
    best.iterations = total.iterations, best.evaluations = total.evaluations;
    best.optimiserSeconds = std::max(0.0, secondsSince(start) - best.renderSeconds - best.similaritySeconds);
    return best;
}

int noLumenSearchCandidates(const RegisterOptions& o) noexcept {
    if (o.noLumenSearch.candidates >= 0) return o.noLumenSearch.candidates;
    return o.method == RegistrationMethod::PqSpace ? kNoLumenSearchCandidates : 0;
}

bool paintsAlbedoMap(const FrameRegistration& r, const RegisterOptions& o) noexcept {
    return r.converged && r.similarity >= o.minPaintSimilarity;
}

frames::Mat4 predictPose(const frames::Mat4& before, const frames::Mat4& last, double damping) noexcept {
    // Relative motion in the camera's frame: M = before^-1 * last = [R | t].
    const Mat3 Rb = rotationOf(before), Rl = rotationOf(last);
    const Mat3 R = Rb.transpose() * Rl;
    const Eigen::Vector3d t = Rb.transpose() * Eigen::Vector3d(last[0][3] - before[0][3], last[1][3] - before[1][3],
                                                               last[2][3] - before[2][3]);
    // Applied again after `last` (last * M: the same numbers, now in last's
    // axes), both parts scaled by the damping.
    const Eigen::AngleAxisd aa(R);
    const Eigen::Vector3d w = aa.axis() * aa.angle() * damping;
    const Eigen::Vector3d tl = t * damping;
    return perturbPose(last, {tl[0], tl[1], tl[2]}, {w[0], w[1], w[2]});
}

PoseError poseError(const frames::Mat4& a, const frames::Mat4& b) noexcept {
    PoseError e;
    const frames::Vec3d ca = frames::cameraCentre(a), cb = frames::cameraCentre(b);
    e.position = std::sqrt((ca[0] - cb[0]) * (ca[0] - cb[0]) + (ca[1] - cb[1]) * (ca[1] - cb[1]) +
                           (ca[2] - cb[2]) * (ca[2] - cb[2]));
    const Mat3 R = rotationOf(a).transpose() * rotationOf(b);
    e.degrees = std::acos(std::clamp((R.trace() - 1) / 2, -1.0, 1.0)) * 180 / M_PI;
    return e;
}

frames::Mat4 perturbPose(const frames::Mat4& m, const frames::Vec3d& t, const frames::Vec3d& w) noexcept {
    const Mat3 R = rotationOf(m);
    const Mat3 Rn = R * rodrigues(w);
    const Eigen::Vector3d tn = R * Eigen::Vector3d(t[0], t[1], t[2]) + Eigen::Vector3d(m[0][3], m[1][3], m[2][3]);
    frames::Mat4 o{};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) o[r][c] = Rn(r, c);
        o[r][3] = tn[r];
    }
    o[3] = {0, 0, 0, 1};
    return o;
}

}  // namespace mucosa::registration
