// The joint robust fit of rho(gamma) * delta(r) and a per-texel albedo
// (DESIGN.md, eq. 8-11), with Ceres. The structure is bundle adjustment's: six
// shared parameters (the "camera") and one albedo block per texel (the
// "points"), so the Schur complement eliminates the albedos and the reduced
// system is 6 x 6 (DENSE_SCHUR).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>

#include <ceres/ceres.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <Eigen/Dense>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/parallel.hpp>
#include <mucosa/fit/fit.hpp>

namespace mucosa::fit {

namespace {

// Residual of one sample, three channels: a_k * rho(gamma) * delta(r) - I_k,
// with rho(1) = 1 built in (c0 = 1 - c1 - c2 - c3) and delta(0) = 1.
// Parameters: cd = [c1, c2, c3, d1, d2, d3], albedo a = [aR, aG, aB].
class ShadingResidual final : public ceres::SizedCostFunction<3, 6, 3> {
public:
    ShadingResidual(double gamma, double r, const std::array<float, 3>& I) : gamma_(gamma), r_(r), I_(I) {}

    bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
        const double* cd = p[0];
        const double* a = p[1];
        const double g = gamma_, g2 = g * g, g3 = g2 * g;
        const double r = r_, r2 = r * r, r3 = r2 * r;
        const double rho = 1.0 + cd[0] * (g - 1.0) + cd[1] * (g2 - 1.0) + cd[2] * (g3 - 1.0);
        const double delta = 1.0 + cd[3] * r + cd[4] * r2 + cd[5] * r3;
        const double shade = rho * delta;
        for (int k = 0; k < 3; ++k) residuals[k] = a[k] * shade - I_[k];
        if (jacobians) {
            if (jacobians[0]) {
                const double dRho[3] = {g - 1.0, g2 - 1.0, g3 - 1.0};
                const double dDelta[3] = {r, r2, r3};
                for (int k = 0; k < 3; ++k) {
                    double* row = jacobians[0] + 6 * k;
                    for (int j = 0; j < 3; ++j) row[j] = a[k] * delta * dRho[j];
                    for (int j = 0; j < 3; ++j) row[3 + j] = a[k] * rho * dDelta[j];
                }
            }
            if (jacobians[1]) {
                double* J = jacobians[1];
                for (int k = 0; k < 9; ++k) J[k] = 0.0;
                for (int k = 0; k < 3; ++k) J[4 * k] = shade;
            }
        }
        return true;
    }

private:
    double gamma_, r_;
    std::array<float, 3> I_;
};

// Levenberg-Marquardt on the joint problem with the albedos eliminated by the
// Schur complement, specialised to this structure (each albedo block is a
// scaled identity, so the reduced system is 6 x 6 and one iteration is one pass
// over the samples), with the Cauchy loss applied by iterative reweighting
// (Triggs et al. 2000, "Bundle adjustment: a modern synthesis", sec. 6 and
// 6.8). Samples are sorted by texel so that each texel's sums are formed by one
// task; tasks cover fixed texel ranges and their partial 6 x 6 sums are added
// in order, so the result does not depend on the thread count. It reaches the
// same minimum as Ceres' DENSE_SCHUR (tested) in a small fraction of the time.
double robustCost(double e2, const FitOptions& o) {
    const double c2 = o.cauchyScale * o.cauchyScale;
    return o.robust ? c2 * std::log1p(e2 / c2) : e2;
}

struct SolveSample {
    float gamma, r;
    float I[3];
};

int schurLevenbergMarquardt(const std::vector<Sample>& samples, const std::vector<std::size_t>& usable,
                            const std::vector<std::uint32_t>& slotOf, const shading::BrdfParams& range, const FitOptions& o,
                            std::array<double, 6>& cd, std::vector<std::array<double, 3>>& albedo, double& finalCost) {
    using Vec6 = Eigen::Matrix<double, 6, 1>;
    using Mat6 = Eigen::Matrix<double, 6, 6>;
    const double span = range.zmax - range.zmin;
    const double c2 = o.cauchyScale * o.cauchyScale;
    const std::size_t T = albedo.size();

    // Samples grouped by texel: begin[t] .. begin[t + 1].
    std::vector<std::size_t> begin(T + 1, 0);
    for (std::uint32_t s : slotOf) begin[s + 1]++;
    for (std::size_t t = 0; t < T; ++t) begin[t + 1] += begin[t];
    std::vector<SolveSample> ss(usable.size());
    {
        std::vector<std::size_t> at(begin.begin(), begin.end() - 1);
        for (std::size_t j = 0; j < usable.size(); ++j) {
            const Sample& s = samples[usable[j]];
            ss[at[slotOf[j]]++] = {s.gamma, static_cast<float>((s.z - range.zmin) / span), {s.I[0], s.I[1], s.I[2]}};
        }
    }
    struct Cell {
        double haa = 0;
        Vec6 hta[3];
        double ba[3] = {0, 0, 0};
    };
    // Everything one pass over the samples yields at a point (p, a): the
    // robust cost and the normal equations (IRLS weights at that point). The
    // damping enters only when solving, so a rejected step re-solves the same
    // equations with more damping and needs no pass of its own.
    struct Linearisation {
        double cost = 0;
        Mat6 H = Mat6::Zero();
        Vec6 b = Vec6::Zero();
        std::vector<Cell> cells;
    };
    constexpr std::size_t kChunk = 256;  // texels per task
    const std::size_t chunks = (T + kChunk - 1) / kChunk;
    std::vector<Mat6> partH(chunks);
    std::vector<Vec6> partB(chunks);
    std::vector<double> partCost(chunks);
    tbb::task_arena arena(resolveThreads(o.threads));

    auto shading = [](const SolveSample& s, const std::array<double, 6>& p, Vec6* grad) {
        const double g = s.gamma, g2 = g * g, g3 = g2 * g;
        const double r = s.r, r2 = r * r, r3 = r2 * r;
        const double rho = 1.0 + p[0] * (g - 1) + p[1] * (g2 - 1) + p[2] * (g3 - 1);
        const double delta = 1.0 + p[3] * r + p[4] * r2 + p[5] * r3;
        if (grad) *grad << delta * (g - 1), delta * (g2 - 1), delta * (g3 - 1), rho * r, rho * r2, rho * r3;
        return rho * delta;
    };
    // Texels t with t % stride == 0 take part (stride 1: all); the others get
    // empty cells, which the step below leaves alone.
    auto linearise = [&](const std::array<double, 6>& p, const std::vector<std::array<double, 3>>& albedoAt,
                         std::size_t stride, Linearisation& out) {
        out.cells.resize(T);
        arena.execute([&] {
            tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t ch) {
                Mat6 H = Mat6::Zero();
                Vec6 b = Vec6::Zero();
                double cost = 0, logSum = 0, product = 1.0;
                int inBatch = 0;
                for (std::size_t t = ch * kChunk; t < std::min(T, (ch + 1) * kChunk); ++t) {
                    Cell& c = out.cells[t];
                    c.haa = 0;
                    for (auto& v : c.hta) v.setZero();
                    c.ba[0] = c.ba[1] = c.ba[2] = 0;
                    if (t % stride != 0) continue;
                    const auto& at = albedoAt[t];
                    const double a2 = at[0] * at[0] + at[1] * at[1] + at[2] * at[2];
                    for (std::size_t j = begin[t]; j < begin[t + 1]; ++j) {
                        Vec6 g;
                        const double m = shading(ss[j], p, &g);
                        double e[3], e2 = 0;
                        for (int k = 0; k < 3; ++k) {
                            e[k] = at[k] * m - ss[j].I[k];
                            e2 += e[k] * e[k];
                        }
                        // Cauchy cost c2 log(1 + e2/c2), one log per batch of
                        // samples: the sum of logs is the log of the product.
                        const double q = 1.0 + e2 / c2;
                        if (o.robust) {
                            product *= q;
                            if (++inBatch == 8 || product > 1e200) {
                                logSum += std::log(product);
                                product = 1.0;
                                inBatch = 0;
                            }
                        } else {
                            cost += e2;
                        }
                        const double w = o.robust ? 1.0 / q : 1.0;  // IRLS weight of the Cauchy loss
                        c.haa += w * m * m;
                        for (int k = 0; k < 3; ++k) {
                            c.hta[k].noalias() += (w * at[k] * m) * g;
                            c.ba[k] += w * m * e[k];
                            b.noalias() += (w * at[k] * e[k]) * g;
                        }
                        const Vec6 wg = (w * a2) * g;
                        for (int i = 0; i < 6; ++i)  // lower triangle; mirrored after the pass
                            for (int k = 0; k <= i; ++k) H(i, k) += wg[i] * g[k];
                    }
                }
                partH[ch] = H;
                partB[ch] = b;
                partCost[ch] = cost + c2 * (logSum + std::log(product));
            });
        });
        out.H.setZero();
        out.b.setZero();
        out.cost = 0;
        for (std::size_t ch = 0; ch < chunks; ++ch) {
            out.H += partH[ch];
            out.b += partB[ch];
            out.cost += partCost[ch];
        }
        out.H.template triangularView<Eigen::StrictlyUpper>() = out.H.transpose();
    };
    // Levenberg-Marquardt from (cd, albedo) on the texels of one stride, until
    // the relative cost gain falls below `tolerance` or the step stalls.
    Linearisation cur, cand;
    std::vector<std::array<double, 3>> aNew;
    int iterations = 0;
    auto run = [&](std::size_t stride, double tolerance) {
        linearise(cd, albedo, stride, cur);
        double lambda = 1e-6;
        for (int it = 0; it < 60; ++it) {
            ++iterations;
            // Schur complement onto the six shared parameters (LM damping on both).
            Mat6 S = cur.H;
            for (int i = 0; i < 6; ++i) S(i, i) += lambda * cur.H(i, i) + 1e-12;
            Vec6 rhs = cur.b;
            for (const Cell& c : cur.cells) {
                if (c.haa <= 0) continue;
                const double inv = 1.0 / (c.haa * (1.0 + lambda));
                for (int k = 0; k < 3; ++k) {
                    S.noalias() -= inv * c.hta[k] * c.hta[k].transpose();
                    rhs.noalias() -= (inv * c.ba[k]) * c.hta[k];
                }
            }
            const Vec6 dt = S.ldlt().solve(-rhs);
            if (!dt.allFinite()) break;
            std::array<double, 6> cdNew = cd;
            for (int i = 0; i < 6; ++i) cdNew[static_cast<std::size_t>(i)] += dt[i];
            aNew = albedo;
            for (std::size_t t = 0; t < T; ++t) {
                const Cell& c = cur.cells[t];
                if (c.haa <= 0) continue;
                for (int k = 0; k < 3; ++k) aNew[t][k] -= (c.ba[k] + c.hta[k].dot(dt)) / (c.haa * (1.0 + lambda));
            }
            linearise(cdNew, aNew, stride, cand);
            if (cand.cost < cur.cost) {
                const double gain = (cur.cost - cand.cost) / std::max(cur.cost, 1e-300);
                cd = cdNew;
                albedo.swap(aNew);
                std::swap(cur, cand);
                lambda = std::max(1e-9, lambda / 3);
                // Converged for all practical purposes: the cost or the step stalls.
                const double size = std::sqrt(cd[0] * cd[0] + cd[1] * cd[1] + cd[2] * cd[2] + cd[3] * cd[3] +
                                              cd[4] * cd[4] + cd[5] * cd[5]);
                if (gain < tolerance || dt.norm() < 1e-5 * (1.0 + size)) break;
            } else {
                lambda *= 10;
                if (lambda > 1e8) break;
            }
        }
    };
    // Coarse to fine: the six shared parameters are well determined by a
    // fraction of the texels, so a first solve on every 8th texel (an eighth
    // of the work per pass) brings them close; the full problem then starts
    // near its minimum and needs only a few passes. The minimum is the full
    // problem's either way.
    if (T >= 2048) run(8, 1e-7);
    run(1, 1e-7);
    finalCost = cur.cost;
    return iterations;
}

// The same joint problem through Ceres (DENSE_SCHUR, Cauchy loss): the
// general-purpose reference the specialised solver is checked against.
int solveWithCeres(const std::vector<Sample>& samples, const std::vector<std::size_t>& usable,
                   const std::vector<std::uint32_t>& slotOf, const shading::BrdfParams& out, const FitOptions& o,
                   std::array<double, 6>& cd, std::vector<std::array<double, 3>>& albedo, double& finalCost) {
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    ceres::CauchyLoss cauchy(o.cauchyScale);
    ceres::LossFunction* loss = o.robust ? &cauchy : nullptr;
    const double span = out.zmax - out.zmin;
    for (std::size_t j = 0; j < usable.size(); ++j) {
        const Sample& s = samples[usable[j]];
        const std::size_t t = slotOf[j];
        problem.AddResidualBlock(new ShadingResidual(s.gamma, (s.z - out.zmin) / span, s.I), loss, cd.data(),
                                 albedo[t].data());
    }
    auto* ordering = new ceres::ParameterBlockOrdering;
    for (auto& a : albedo) ordering->AddElementToGroup(a.data(), 0);
    ordering->AddElementToGroup(cd.data(), 1);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_SCHUR;
    so.linear_solver_ordering.reset(ordering);
    so.num_threads = resolveThreads(o.threads);
    so.max_num_iterations = 100;
    so.function_tolerance = 1e-9;
    so.parameter_tolerance = 1e-9;
    so.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    if (summary.termination_type == ceres::FAILURE)
        throw InputError("fit", "", "the solver failed: " + summary.message);
    finalCost = 2.0 * summary.final_cost;  // Ceres minimises half the sum
    return static_cast<int>(summary.iterations.size());
}

}  // namespace

shading::BrdfParams solveBrdf(const std::vector<Sample>& samples, const FitOptions& o, FitResult* diag) {
    const auto t0 = std::chrono::steady_clock::now();
    if (samples.size() < o.minSamples)
        throw InputError("samples", "",
                         fmt::format("only {} usable samples; at least {} are needed (more frames, or frames that "
                                     "see more of the mesh)",
                                     samples.size(), o.minSamples));
    shading::BrdfParams out;
    float zmin = samples[0].z, zmax = samples[0].z;
    float umin = samples[0].u, umax = samples[0].u, vmin = samples[0].v, vmax = samples[0].v;
    for (const Sample& s : samples) {
        zmin = std::min(zmin, s.z);
        zmax = std::max(zmax, s.z);
        umin = std::min(umin, s.u);
        umax = std::max(umax, s.u);
        vmin = std::min(vmin, s.v);
        vmax = std::max(vmax, s.v);
    }
    if (!(zmax > zmin))
        throw InputError("samples", "", "all samples are at the same distance: delta(r) cannot be fitted");
    out.zmin = zmin;
    out.zmax = zmax;

    // Albedo grid of the solve; a texel carries information only when more
    // than one frame saw it.
    const int G = std::max(8, o.fitGrid);
    const float du = std::max(1e-6f, umax - umin), dv = std::max(1e-6f, vmax - vmin);
    auto cellOf = [&](const Sample& s) {
        const int x = std::clamp(static_cast<int>((s.u - umin) / du * G), 0, G - 1);
        const int y = std::clamp(static_cast<int>((s.v - vmin) / dv * G), 0, G - 1);
        return y * G + x;
    };
    std::vector<std::uint32_t> firstFrame(static_cast<std::size_t>(G) * G, UINT32_MAX);
    std::vector<std::uint8_t> multi(firstFrame.size(), 0);
    for (const Sample& s : samples) {
        const int c = cellOf(s);
        if (firstFrame[c] == UINT32_MAX)
            firstFrame[c] = s.frame;
        else if (firstFrame[c] != s.frame)
            multi[c] = 1;
    }
    std::vector<std::size_t> usable;
    for (std::size_t i = 0; i < samples.size(); ++i)
        if (multi[cellOf(samples[i])]) usable.push_back(i);
    if (usable.size() < o.minSamples)
        throw InputError("samples", "",
                         fmt::format("only {} samples lie on surface seen by two or more frames; the fit needs "
                                     "overlapping views (at least {})",
                                     usable.size(), o.minSamples));
    std::mt19937_64 rng(o.seed);
    if (usable.size() > o.maxSolveSamples) {
        std::shuffle(usable.begin(), usable.end(), rng);
        usable.resize(o.maxSolveSamples);
        std::sort(usable.begin(), usable.end());
    }

    // Parameters: start from flat shading, albedo = mean intensity per cell.
    std::array<double, 6> cd{0, 0, 0, 0, 0, 0};
    std::vector<std::uint32_t> slot(firstFrame.size(), UINT32_MAX);  // cell -> albedo index
    std::vector<std::array<double, 3>> albedo;
    std::vector<double> count;
    for (std::size_t i : usable) {
        std::uint32_t& sl = slot[static_cast<std::size_t>(cellOf(samples[i]))];
        if (sl == UINT32_MAX) {
            sl = static_cast<std::uint32_t>(albedo.size());
            albedo.push_back({0, 0, 0});
            count.push_back(0);
        }
        for (int k = 0; k < 3; ++k) albedo[sl][k] += samples[i].I[k];
        count[sl] += 1;
    }
    for (std::size_t t = 0; t < albedo.size(); ++t)
        for (int k = 0; k < 3; ++k) albedo[t][k] /= count[t];

    std::vector<std::uint32_t> slotOf(usable.size());
    for (std::size_t j = 0; j < usable.size(); ++j)
        slotOf[j] = slot[static_cast<std::size_t>(cellOf(samples[usable[j]]))];
    int iterations = 0;
    double finalCost = 0;
    if (o.solver == Solver::Schur)
        iterations = schurLevenbergMarquardt(samples, usable, slotOf, out, o, cd, albedo, finalCost);
    else
        iterations = solveWithCeres(samples, usable, slotOf, out, o, cd, albedo, finalCost);

    out.c = {1.0 - cd[0] - cd[1] - cd[2], cd[0], cd[1], cd[2]};
    out.d = {cd[3], cd[4], cd[5]};
    out.samples = usable.size();

    // RMS over inliers (highlights excluded by the same 3-sigma-of-loss rule).
    double sum = 0;
    std::size_t n = 0;
    std::vector<std::array<double, 3>> rhoAcc(20, {0, 0, 0}), deltaAcc(20, {0, 0, 0});
    for (std::size_t i : usable) {
        const Sample& s = samples[i];
        const auto& a = albedo[slot[static_cast<std::size_t>(cellOf(s))]];
        const double rr = out.r(s.z), rho = out.rho(s.gamma), delta = out.delta(rr);
        double e2 = 0;
        for (int k = 0; k < 3; ++k) {
            const double e = a[k] * rho * delta - s.I[k];
            e2 += e * e;
        }
        if (e2 < 9.0 * o.cauchyScale * o.cauchyScale * 3.0) {
            sum += e2;
            n += 3;
            const double lum = (s.I[0] + s.I[1] + s.I[2]) / 3.0, alum = (a[0] + a[1] + a[2]) / 3.0;
            if (alum > 1e-4) {
                auto& rb = rhoAcc[std::min<std::size_t>(19, static_cast<std::size_t>(s.gamma * 20))];
                rb[0] += s.gamma;
                rb[1] += lum / (alum * delta);
                rb[2] += 1;
                auto& db = deltaAcc[std::min<std::size_t>(19, static_cast<std::size_t>(std::max(0.0, rr) * 20))];
                db[0] += rr;
                db[1] += lum / (alum * rho);
                db[2] += 1;
            }
        }
    }
    out.rms = n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
    if (diag) {
        diag->solveSamples = usable.size();
        diag->solveTexels = albedo.size();
        diag->solverIterations = iterations;
        diag->solveCost = finalCost;
        std::vector<float> zs;
        zs.reserve(usable.size());
        for (std::size_t i : usable) zs.push_back(samples[i].z);
        std::nth_element(zs.begin(), zs.begin() + static_cast<std::ptrdiff_t>(zs.size() / 100), zs.end());
        const float lo = zs[zs.size() / 100];
        std::nth_element(zs.begin(), zs.begin() + static_cast<std::ptrdiff_t>(zs.size() * 99 / 100), zs.end());
        diag->zObserved = {lo, zs[zs.size() * 99 / 100]};
        diag->solveSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        diag->rhoBins.clear();
        diag->deltaBins.clear();
        for (const auto& b : rhoAcc)
            if (b[2] > 20) diag->rhoBins.push_back({b[0] / b[2], b[1] / b[2], b[2]});
        for (const auto& b : deltaAcc)
            if (b[2] > 20) diag->deltaBins.push_back({b[0] / b[2], b[1] / b[2], b[2]});
    }
    return out;
}

}  // namespace mucosa::fit
