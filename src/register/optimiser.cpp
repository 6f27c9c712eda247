// The optimiser: one frame registered from a starting pose, coarse to fine,
// by Levenberg-Marquardt on the objective with a central-difference
// Jacobian (registerFrame); the pose's uncertainty from the finest level's
// normal equations, and how deep the view is at the estimate.
#include <mucosa/register/register.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <Eigen/Dense>

#include <mucosa/core/error.hpp>
#include <mucosa/core/parallel.hpp>

#include "phases.hpp"

namespace mucosa::registration {

using detail::Clock;
using detail::Mat3;
using detail::Neighbourhood;
using detail::neighbourhood;
using detail::Objective;
using detail::percentile;
using detail::robustCost;
using detail::rotationOf;
using detail::secondsSince;

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
    // 0.94 where the finest level alone went, before the fields compared normals). When the coarse levels moved
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

}  // namespace mucosa::registration
