// The joint robust fit of rho(gamma) * delta(r) and a per-texel albedo
// (DESIGN.md, eq. 8-11), with Ceres. The structure is bundle adjustment's: six
// shared parameters (the "camera") and one albedo block per texel (the
// "points"), so the Schur complement eliminates the albedos and the reduced
// system is 6 x 6 (DENSE_SCHUR).
#include <mucosa/fit/fit.hpp>

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

namespace mucosa::fit {

namespace {

// How the last three of the six shared parameters make delta's d1..d3.
//   Free: theta = (d1, d2, d3).
//   Lamp: theta = (e1, e2, e3) >= 0, the steps down delta's Bernstein
//         control polygon on [0, 1]: b0 = 1, b1 = 1 - e1, b2 = b1 - e2,
//         b3 = b2 - e3, delta(r) = sum_i b_i C(3, i) r^i (1 - r)^(3 - i).
//         A cubic's derivative is 3 sum_i (b_(i+1) - b_i) B_i^2(r) (Farin,
//         "Curves and surfaces for CAGD", sec. 5.3), so e >= 0 makes delta
//         non-increasing on [0, 1]: a sufficient condition, reached by every
//         decreasing shape a lamp gives (1 - r)^3, the steepest with a flat
//         end, has e = (1, 0, 0)), and linear, so both solvers handle it as
//         bounds: Ceres natively, the Schur solver by an active set.
//         In the power basis: d1 = -3 e1, d2 = 3 e1 - 3 e2, d3 = -e1 + 2 e2 - e3.
enum class DeltaForm { Free, Lamp };

struct DeltaMap {
    std::array<double, 3> d;
    std::array<std::array<double, 3>, 3> J;  // J[i][j] = d d_i / d theta_j
};

constexpr std::array<std::array<double, 3>, 3> kBernsteinSteps{{{-3.0, 0.0, 0.0}, {3.0, -3.0, 0.0}, {-1.0, 2.0, -1.0}}};

DeltaMap deltaMap(DeltaForm form, const double* theta) {
    DeltaMap m{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m.J[i][j] = form == DeltaForm::Free ? (i == j ? 1.0 : 0.0) : kBernsteinSteps[i][j];
    for (int i = 0; i < 3; ++i) m.d[i] = m.J[i][0] * theta[0] + m.J[i][1] * theta[1] + m.J[i][2] * theta[2];
    return m;
}

// Residual of one sample, three channels: a_k * rho(gamma) * delta(r) - I_k,
// with rho(1) = 1 built in (c0 = 1 - c1 - c2 - c3) and delta(0) = 1.
// Parameters: cd = [c1, c2, c3, theta0..2] (theta: see DeltaMap), albedo a = [aR, aG, aB].
class ShadingResidual final : public ceres::SizedCostFunction<3, 6, 3> {
public:
    ShadingResidual(double gamma, double r, const std::array<float, 3>& I, DeltaForm form)
        : gamma_(gamma), r_(r), I_(I), form_(form) {}

    bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
        const double* cd = p[0];
        const double* a = p[1];
        const DeltaMap dm = deltaMap(form_, cd + 3);
        const double g = gamma_, g2 = g * g, g3 = g2 * g;
        const double r = r_, r2 = r * r, r3 = r2 * r;
        const double rho = 1.0 + cd[0] * (g - 1.0) + cd[1] * (g2 - 1.0) + cd[2] * (g3 - 1.0);
        const double delta = 1.0 + dm.d[0] * r + dm.d[1] * r2 + dm.d[2] * r3;
        const double shade = rho * delta;
        for (int k = 0; k < 3; ++k) residuals[k] = a[k] * shade - I_[k];
        if (jacobians) {
            if (jacobians[0]) {
                const double dRho[3] = {g - 1.0, g2 - 1.0, g3 - 1.0};
                const double dD[3] = {r, r2, r3};
                double dTheta[3];
                for (int j = 0; j < 3; ++j) dTheta[j] = dD[0] * dm.J[0][j] + dD[1] * dm.J[1][j] + dD[2] * dm.J[2][j];
                for (int k = 0; k < 3; ++k) {
                    double* row = jacobians[0] + 6 * k;
                    for (int j = 0; j < 3; ++j) row[j] = a[k] * delta * dRho[j];
                    for (int j = 0; j < 3; ++j) row[3 + j] = a[k] * rho * dTheta[j];
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
    DeltaForm form_;
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
struct SolveSample {
    float gamma, r;
    float I[3];
};

int schurLevenbergMarquardt(const std::vector<Sample>& samples, const std::vector<std::size_t>& usable,
                            const std::vector<std::uint32_t>& slotOf, const shading::BrdfParams& range,
                            const FitOptions& o, DeltaForm form, std::array<double, 6>& cd,
                            std::vector<std::array<double, 3>>& albedo, double& finalCost) {
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
            ss[at[slotOf[j]]++] = {
                s.gamma, static_cast<float>(std::clamp((s.z - range.zmin) / span, 0.0, 1.0)), {s.I[0], s.I[1], s.I[2]}};
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

    auto shading = [](const SolveSample& s, const std::array<double, 6>& p, const DeltaMap& dm, Vec6* grad) {
        const double g = s.gamma, g2 = g * g, g3 = g2 * g;
        const double r = s.r, r2 = r * r, r3 = r2 * r;
        const double rho = 1.0 + p[0] * (g - 1) + p[1] * (g2 - 1) + p[2] * (g3 - 1);
        const double delta = 1.0 + dm.d[0] * r + dm.d[1] * r2 + dm.d[2] * r3;
        if (grad) {
            double t[3];
            for (int j = 0; j < 3; ++j) t[j] = rho * (r * dm.J[0][j] + r2 * dm.J[1][j] + r3 * dm.J[2][j]);
            *grad << delta * (g - 1), delta * (g2 - 1), delta * (g3 - 1), t[0], t[1], t[2];
        }
        return rho * delta;
    };
    // Texels t with t % stride == 0 take part (stride 1: all); the others get
    // empty cells, which the step below leaves alone.
    auto linearise = [&](const std::array<double, 6>& p, const std::vector<std::array<double, 3>>& albedoAt,
                         std::size_t stride, Linearisation& out) {
        out.cells.resize(T);
        const DeltaMap dm = deltaMap(form, p.data() + 3);
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
                        const double m = shading(ss[j], p, dm, &g);
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
    // Each texel's albedo given the shared parameters is a weighted linear
    // least-squares problem of its own: after a step, it is solved again in
    // closed form at the new shared parameters (one reweighting step, with the
    // Cauchy weights of the stepped point: for a loss concave in e^2 this
    // never raises the cost, and without the loss it is the exact minimum).
    // This is the embedded point iteration of bundle adjustment (Triggs et al.
    // 2000, sec. 4.4; variable projection in effect): the albedos follow the
    // shared parameters at once instead of lagging behind them under the
    // damping, which on a fall-off whose cubic terms trade off against each
    // other left plain LM crawling along the valley (ten frames of a lamp:
    // the free fit stopped at its iteration cap at cost 14.1, where the
    // minimum is 6.56).
    auto refitAlbedo = [&](const std::array<double, 6>& p, std::vector<std::array<double, 3>>& a, std::size_t stride) {
        const DeltaMap dm = deltaMap(form, p.data() + 3);
        arena.execute([&] {
            tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t ch) {
                for (std::size_t t = ch * kChunk; t < std::min(T, (ch + 1) * kChunk); ++t) {
                    if (t % stride != 0 || begin[t] == begin[t + 1]) continue;
                    double mm = 0, mi[3] = {0, 0, 0};
                    for (std::size_t j = begin[t]; j < begin[t + 1]; ++j) {
                        const double m = shading(ss[j], p, dm, nullptr);
                        double w = 1.0;
                        if (o.robust) {
                            double e2 = 0;
                            for (int k = 0; k < 3; ++k) {
                                const double e = a[t][static_cast<std::size_t>(k)] * m - ss[j].I[k];
                                e2 += e * e;
                            }
                            w = 1.0 / (1.0 + e2 / c2);
                        }
                        mm += w * m * m;
                        for (int k = 0; k < 3; ++k) mi[k] += w * m * ss[j].I[k];
                    }
                    if (mm > 1e-300)
                        for (int k = 0; k < 3; ++k) a[t][static_cast<std::size_t>(k)] = mi[k] / mm;
                }
            });
        });
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
            // Marquardt's scaling, floored so that a direction the data barely
            // constrain (the fall-off's parameters near the edge of the lamp
            // constraint) is still damped.
            const double floor = 1e-9 * cur.H.diagonal().maxCoeff() + 1e-12;
            Mat6 S = cur.H;
            for (int i = 0; i < 6; ++i) S(i, i) += lambda * std::max(cur.H(i, i), floor) + 1e-12;
            Vec6 rhs = cur.b;
            for (const Cell& c : cur.cells) {
                if (c.haa <= 0) continue;
                const double inv = 1.0 / (c.haa * (1.0 + lambda));
                for (int k = 0; k < 3; ++k) {
                    S.noalias() -= inv * c.hta[k] * c.hta[k].transpose();
                    rhs.noalias() -= (inv * c.ba[k]) * c.hta[k];
                }
            }
            // The step; with the lamp's bounds (theta 3..5 >= 0), an active
            // set: a step that would cross a bound stops on it, and the other
            // parameters are solved again with it held.
            Vec6 dt = S.ldlt().solve(-rhs);
            if (form == DeltaForm::Lamp) {
                std::array<bool, 6> held{};
                for (int round = 0; round < 3 && dt.allFinite(); ++round) {
                    bool crossed = false;
                    for (int i = 3; i < 6; ++i)
                        if (!held[static_cast<std::size_t>(i)] && cd[static_cast<std::size_t>(i)] + dt[i] < 0) {
                            held[static_cast<std::size_t>(i)] = true;
                            crossed = true;
                        }
                    if (!crossed) break;
                    Mat6 Sh = S;
                    Vec6 bh = -rhs;
                    for (int i = 0; i < 6; ++i) {
                        if (!held[static_cast<std::size_t>(i)]) continue;
                        const double fixedStep = -cd[static_cast<std::size_t>(i)];
                        bh -= S.col(i) * fixedStep;
                        Sh.row(i).setZero();
                        Sh.col(i).setZero();
                        Sh(i, i) = 1.0;
                        bh[i] = fixedStep;
                    }
                    dt = Sh.ldlt().solve(bh);
                }
            }
            if (!dt.allFinite()) {
                lambda *= 10;
                if (lambda > 1e8) break;
                continue;
            }
            std::array<double, 6> cdNew = cd;
            for (int i = 0; i < 6; ++i) cdNew[static_cast<std::size_t>(i)] += dt[i];
            aNew = albedo;
            for (std::size_t t = 0; t < T; ++t) {
                const Cell& c = cur.cells[t];
                if (c.haa <= 0) continue;
                for (int k = 0; k < 3; ++k) aNew[t][k] -= (c.ba[k] + c.hta[k].dot(dt)) / (c.haa * (1.0 + lambda));
            }
            refitAlbedo(cdNew, aNew, stride);
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
                   DeltaForm form, std::array<double, 6>& cd, std::vector<std::array<double, 3>>& albedo,
                   double& finalCost) {
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
        problem.AddResidualBlock(new ShadingResidual(s.gamma, std::clamp((s.z - out.zmin) / span, 0.0, 1.0), s.I, form),
                                 loss, cd.data(), albedo[t].data());
    }
    if (form == DeltaForm::Lamp)  // the Bernstein steps are bounded below by 0
        for (int i = 3; i < 6; ++i) problem.SetParameterLowerBound(cd.data(), i, 0.0);
    auto* ordering = new ceres::ParameterBlockOrdering;
    for (auto& a : albedo) ordering->AddElementToGroup(a.data(), 0);
    ordering->AddElementToGroup(cd.data(), 1);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_SCHUR;
    so.linear_solver_ordering.reset(ordering);
    so.num_threads = resolveThreads(o.threads);
    so.max_num_iterations = 500;
    // Inner iterations: after each step the albedo blocks are re-optimised
    // on their own (Ceres' simplified variable projection), as the
    // specialised solver does; without them Ceres crawled along the
    // fall-off's valley (a cost 25 % above the minimum after 1000 steps).
    so.use_inner_iterations = true;
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

// A free cubic's rise on [0, 1] below this is rounding, not data.
constexpr double kRiseTolerance = 1e-9;
// ... and worth a warning when it shows: by more than this in delta (which
// is 1 at r = 0), or by more than kRiseWarningShare of the light where it
// started rising when that light is not darkness (far tissue 10 % brighter
// than nearer tissue is plainly visible: 0.10 to 0.12 as plainly as 0.5 to 0.6).
constexpr double kRiseWarning = 0.02;
constexpr double kRiseWarningShare = 0.10, kRiseWarningLit = 0.05;

bool riseShows(const DeltaRise& r) {
    return r.amount > kRiseWarning || (r.deltaFrom > kRiseWarningLit && r.amount > kRiseWarningShare * r.deltaFrom);
}

// The largest rise of delta over [0, 1]: max over r0 < r1 of delta(r1) -
// delta(r0), on a fine grid, with where it starts and ends.
DeltaRise deltaRise(const std::array<double, 3>& d) {
    auto delta = [&](double r) { return 1.0 + r * (d[0] + r * (d[1] + r * d[2])); };
    DeltaRise best;
    double lo = 1.0, loAt = 0.0;
    constexpr int kSteps = 1000;
    for (int i = 1; i <= kSteps; ++i) {
        const double r = static_cast<double>(i) / kSteps, v = delta(r);
        if (v - lo > best.amount) best = {v - lo, loAt, r, lo, v};
        if (v < lo) {
            lo = v;
            loAt = r;
        }
    }
    return best;
}

}  // namespace

double fittedShading(const shading::BrdfParams& b, double gamma, double z) noexcept {
    return b.rho(gamma) * b.delta(std::clamp(b.r(z), 0.0, 1.0));
}

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
    // zmax candidates: quantiles of the distances, not only the farthest
    // sample. The farthest few (the far lumen, a wall seen through an
    // opening) are dark and too few to shape a cubic, and a lamp's 1/z^2 is
    // steeper than any cubic over a long range; beyond zmax delta is held at
    // delta(1) (r clamped, as the renderer does), so every candidate predicts
    // every sample and the one that explains them best is kept.
    std::vector<double> zmaxCandidates;
    {
        std::vector<float> zs(samples.size());
        for (std::size_t i = 0; i < samples.size(); ++i) zs[i] = samples[i].z;
        for (double q : o.zmaxQuantiles) {
            const auto k = static_cast<std::ptrdiff_t>(std::clamp(q, 0.5, 1.0) * static_cast<double>(zs.size() - 1));
            std::nth_element(zs.begin(), zs.begin() + k, zs.end());
            const double z = zs[static_cast<std::size_t>(k)];
            if (z > zmin && std::find(zmaxCandidates.begin(), zmaxCandidates.end(), z) == zmaxCandidates.end())
                zmaxCandidates.push_back(z);
        }
        if (zmaxCandidates.empty()) zmaxCandidates.push_back(zmax);
    }
    out.zmin = zmin;
    out.zmax = zmax;

    // Albedo grid of the solve; a texel carries information only when more
    // than one frame saw it.
    const int G = std::max(8, o.fitGrid);
    const float du = std::max(1e-6f, umax - umin), dv = std::max(1e-6f, vmax - vmin);
    auto cellOf = [&](const Sample& s) {
        const int x = std::clamp(static_cast<int>((s.u - umin) / du * static_cast<float>(G)), 0, G - 1);
        const int y = std::clamp(static_cast<int>((s.v - vmin) / dv * static_cast<float>(G)), 0, G - 1);
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
    auto solve = [&](DeltaForm form, std::array<double, 6>& theta, std::vector<std::array<double, 3>>& a,
                     double& cost) {
        return o.solver == Solver::Schur
                   ? schurLevenbergMarquardt(samples, usable, slotOf, out, o, form, theta, a, cost)
                   : solveWithCeres(samples, usable, slotOf, out, o, form, theta, a, cost);
    };
    // First the paper's free cubic; when the data make it rise anywhere on
    // [0, 1], which no lamp does (its light only spreads with distance),
    // again with delta constrained to be non-increasing, from the free
    // solution's rho and albedos (docs/theory.md, "The fall-off is a lamp's").
    const std::array<double, 6> cdStart = cd;
    const std::vector<std::array<double, 3>> albedoStart = albedo;
    std::array<double, 6> bestCd{};
    std::vector<std::array<double, 3>> bestAlbedo;
    FalloffCheck bestCheck;
    double bestCost = 1e300, bestZmax = zmax;
    int iterations = 0;
    for (const double zmaxCandidate : zmaxCandidates) {
        out.zmax = zmaxCandidate;
        cd = cdStart;
        albedo = albedoStart;
        double finalCost = 0;
        iterations += solve(DeltaForm::Free, cd, albedo, finalCost);
        FalloffCheck check;
        check.freeD = {cd[3], cd[4], cd[5]};
        check.freeCost = finalCost;
        check.rise = deltaRise(check.freeD);
        if (o.monotoneDelta && check.rise.amount > kRiseTolerance) {
            check.constrained = true;
            // Start: the lamp-shaped delta closest to the free one where the
            // samples are (least squares over r weighted by their density, e >= 0
            // by trying every set of steps held at 0), and each texel's albedo
            // refitted to it; then the joint solve from there.
            const double span = out.zmax - out.zmin;
            constexpr int kBins = 64;
            std::array<double, kBins> density{};
            for (std::size_t i : usable) {
                const double rr = std::clamp((samples[i].z - out.zmin) / span, 0.0, 1.0);
                density[static_cast<std::size_t>(std::min(kBins - 1, static_cast<int>(rr * kBins)))] += 1;
            }
            std::array<double, 3> bestE{0, 0, 0};
            double bestMisfit = 1e300;
            for (int subset = 0; subset < 8; ++subset) {
                Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
                Eigen::Vector3d b = Eigen::Vector3d::Zero();
                for (int k = 0; k < kBins; ++k) {
                    const double rr = (k + 0.5) / kBins, w = density[static_cast<std::size_t>(k)];
                    const double target =
                        check.freeD[0] * rr + check.freeD[1] * rr * rr + check.freeD[2] * rr * rr * rr;
                    Eigen::Vector3d g;  // d delta / d e at rr
                    for (int j = 0; j < 3; ++j)
                        g[j] = subset & (1 << j) ? rr * kBernsteinSteps[0][j] + rr * rr * kBernsteinSteps[1][j] +
                                                       rr * rr * rr * kBernsteinSteps[2][j]
                                                 : 0.0;
                    A += w * g * g.transpose();
                    b += w * target * g;
                }
                for (int j = 0; j < 3; ++j)
                    if (!(subset & (1 << j))) A(j, j) = 1.0;
                const Eigen::Vector3d e = A.ldlt().solve(b);
                if (!e.allFinite() || e.minCoeff() < 0) continue;
                const DeltaMap dm = deltaMap(DeltaForm::Lamp, e.data());
                double misfit = 0;
                for (int k = 0; k < kBins; ++k) {
                    const double rr = (k + 0.5) / kBins;
                    const double diff = (dm.d[0] - check.freeD[0]) * rr + (dm.d[1] - check.freeD[1]) * rr * rr +
                                        (dm.d[2] - check.freeD[2]) * rr * rr * rr;
                    misfit += density[static_cast<std::size_t>(k)] * diff * diff;
                }
                if (misfit < bestMisfit) {
                    bestMisfit = misfit;
                    bestE = {e[0], e[1], e[2]};
                }
            }
            for (int i = 0; i < 3; ++i) cd[static_cast<std::size_t>(3 + i)] = bestE[static_cast<std::size_t>(i)];
            {
                shading::BrdfParams start = out;
                start.c = {1.0 - cd[0] - cd[1] - cd[2], cd[0], cd[1], cd[2]};
                start.d = deltaMap(DeltaForm::Lamp, cd.data() + 3).d;
                std::vector<std::array<double, 4>> acc(albedo.size(), {0, 0, 0, 0});
                for (std::size_t j = 0; j < usable.size(); ++j) {
                    const Sample& smp = samples[usable[j]];
                    const double m = fittedShading(start, smp.gamma, smp.z);
                    auto& a = acc[slotOf[j]];
                    for (int k = 0; k < 3; ++k) a[static_cast<std::size_t>(k)] += m * smp.I[k];
                    a[3] += m * m;
                }
                for (std::size_t t = 0; t < albedo.size(); ++t)
                    if (acc[t][3] > 1e-12)
                        for (int k = 0; k < 3; ++k)
                            albedo[t][static_cast<std::size_t>(k)] = acc[t][static_cast<std::size_t>(k)] / acc[t][3];
            }
            iterations += solve(DeltaForm::Lamp, cd, albedo, finalCost);
            const DeltaMap dm = deltaMap(DeltaForm::Lamp, cd.data() + 3);
            for (int i = 0; i < 3; ++i) cd[static_cast<std::size_t>(3 + i)] = dm.d[static_cast<std::size_t>(i)];
            check.constrainedCost = finalCost;
            std::size_t inRise = 0;
            for (std::size_t i : usable) {
                const double rr = std::clamp((samples[i].z - out.zmin) / span, 0.0, 1.0);
                inRise += rr >= check.rise.from && rr <= check.rise.to;
            }
            check.riseSampleFraction = static_cast<double>(inRise) / static_cast<double>(usable.size());
        }
        if (finalCost < bestCost) {
            bestCost = finalCost;
            bestCd = cd;
            bestAlbedo = albedo;
            bestCheck = check;
            bestZmax = zmaxCandidate;
        }
    }
    cd = bestCd;
    albedo.swap(bestAlbedo);
    out.zmax = bestZmax;
    const FalloffCheck check = bestCheck;
    const double finalCost = bestCost;

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
        const double rr = std::clamp(out.r(s.z), 0.0, 1.0), rho = out.rho(s.gamma), delta = out.delta(rr);
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
        diag->falloff = check;
        if (check.constrained && riseShows(check.rise))
            diag->warnings.push_back(fmt::format(
                "the fitted fall-off delta(r) rose with distance, from {:.3f} at r = {:.2f} (z = {:.1f} mm) to {:.3f} "
                "at r = {:.2f} (z = {:.1f} mm), where {:.1f} % of the samples lie; a lamp's light cannot grow with "
                "distance, so delta was refitted non-increasing (robust cost {:+.1f} %); check the frames' gamma and "
                "exposure, or add frames that look down the lumen",
                check.rise.deltaFrom, check.rise.from, out.zmin + check.rise.from * (out.zmax - out.zmin),
                check.rise.deltaTo, check.rise.to, out.zmin + check.rise.to * (out.zmax - out.zmin),
                100.0 * check.riseSampleFraction, 100.0 * (check.constrainedCost / check.freeCost - 1.0)));
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
