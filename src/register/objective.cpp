// The objective a pose is scored by: per pixel, the difference of the
// video's and the model's normals (pq) or of their z-scored intensities (the
// baseline), under a Cauchy loss; and the similarities reported.
#include <mucosa/register/register.hpp>

#include <algorithm>
#include <cmath>

#include "phases.hpp"

namespace mucosa::registration {

using detail::Clock;
using detail::secondsSince;

namespace {

constexpr double kUnseen2 = 0.3;  // |n_video - n_model|^2 charged for a pixel the model does not see

}  // namespace

namespace detail {

Objective::Objective(const mesh::Mesh& m, const VideoFrame::Level& l, const RegisterOptions& opt, FrameRegistration& st)
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

std::vector<double> Objective::differences(const frames::Mat4& pose, double* similarity,
                                           std::vector<std::uint8_t>* seen) {
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

}  // namespace detail

const char* methodName(RegistrationMethod m) noexcept {
    return m == RegistrationMethod::PqSpace ? "pq" : "intensity";
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

}  // namespace mucosa::registration
