#include <mucosa/tune/observer.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>

namespace mucosa::tune {

namespace {

using Matrix = std::vector<std::vector<double>>;

// Solves A x = b for a symmetric positive definite A (Cholesky); A is overwritten.
std::vector<double> solveSpd(Matrix A, std::vector<double> b) {
    const std::size_t n = b.size();
    for (std::size_t j = 0; j < n; ++j) {
        double d = A[j][j];
        for (std::size_t k = 0; k < j; ++k) d -= A[j][k] * A[j][k];
        MUCOSA_CHECK(d > 0, "the logistic Hessian is not positive definite");
        A[j][j] = std::sqrt(d);
        for (std::size_t i = j + 1; i < n; ++i) {
            double s = A[i][j];
            for (std::size_t k = 0; k < j; ++k) s -= A[i][k] * A[j][k];
            A[i][j] = s / A[j][j];
        }
    }
    for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t k = 0; k < i; ++k) b[i] -= A[i][k] * b[k];
        b[i] /= A[i][i];
    }
    for (std::size_t i = n; i-- > 0;) {
        for (std::size_t k = i + 1; k < n; ++k) b[i] -= A[k][i] * b[k];
        b[i] /= A[i][i];
    }
    return b;
}

// log(1 + exp(t)), without overflow.
double softplus(double t) {
    return t > 0 ? t + std::log1p(std::exp(-t)) : std::log1p(std::exp(t));
}

}  // namespace

double LogisticModel::decision(const std::vector<double>& x) const {
    double s = b;
    for (std::size_t j = 0; j < w.size(); ++j) s += w[j] * x[j];
    return s;
}

LogisticModel fitLogistic(const Matrix& x, const std::vector<int>& y, const std::vector<double>& weight, double C) {
    MUCOSA_CHECK(!x.empty() && x.size() == y.size() && y.size() == weight.size() && C > 0,
                 "fitLogistic needs one label and weight per row");
    const std::size_t n = x.size(), d = x[0].size(), p = d + 1;  // the intercept last
    std::vector<double> theta(p, 0.0);
    auto objective = [&](const std::vector<double>& t) {
        double f = 0;
        for (std::size_t j = 0; j < d; ++j) f += 0.5 * t[j] * t[j];
        for (std::size_t i = 0; i < n; ++i) {
            double z = t[d];
            for (std::size_t j = 0; j < d; ++j) z += t[j] * x[i][j];
            f += C * weight[i] * softplus(-y[i] * z);
        }
        return f;
    };
    double f = objective(theta);
    for (int iter = 0; iter < 100; ++iter) {
        std::vector<double> g(p, 0.0);
        Matrix H(p, std::vector<double>(p, 0.0));
        for (std::size_t j = 0; j < d; ++j) {
            g[j] = theta[j];
            H[j][j] = 1.0;
        }
        for (std::size_t i = 0; i < n; ++i) {
            double z = theta[d];
            for (std::size_t j = 0; j < d; ++j) z += theta[j] * x[i][j];
            const double sig = 1.0 / (1.0 + std::exp(y[i] * z));  // sigma(-y z)
            const double gi = -C * weight[i] * y[i] * sig;
            const double hi = C * weight[i] * sig * (1.0 - sig);
            for (std::size_t a = 0; a < p; ++a) {
                const double xa = a < d ? x[i][a] : 1.0;
                g[a] += gi * xa;
                for (std::size_t c = 0; c <= a; ++c) H[a][c] += hi * xa * (c < d ? x[i][c] : 1.0);
            }
        }
        double gmax = 0;
        for (double v : g) gmax = std::max(gmax, std::abs(v));
        if (gmax < 1e-10) break;
        for (std::size_t a = 0; a < p; ++a)
            for (std::size_t c = a + 1; c < p; ++c) H[a][c] = H[c][a];
        H[d][d] += 1e-12;  // the intercept alone is unregularised: keep the system definite
        const std::vector<double> step = solveSpd(H, g);
        // Backtracking on the (convex) objective.
        double scale = 1.0;
        std::vector<double> next(p);
        for (int k = 0; k < 40; ++k, scale *= 0.5) {
            for (std::size_t a = 0; a < p; ++a) next[a] = theta[a] - scale * step[a];
            const double fn = objective(next);
            if (fn <= f) {
                f = fn;
                break;
            }
        }
        theta = next;
    }
    LogisticModel m;
    m.w.assign(theta.begin(), theta.begin() + static_cast<std::ptrdiff_t>(d));
    m.b = theta[d];
    return m;
}

double rocAuc(const std::vector<double>& pos, const std::vector<double>& neg) {
    if (pos.empty() || neg.empty()) return std::numeric_limits<double>::quiet_NaN();
    double s = 0;
    for (double p : pos)
        for (double q : neg) s += p > q ? 1.0 : (p == q ? 0.5 : 0.0);
    return s / (static_cast<double>(pos.size()) * static_cast<double>(neg.size()));
}

ObserverResult logisticObserver(const std::vector<FrameStats>& real, const std::vector<FrameStats>& ours, int groups) {
    if (real.size() < 2 || ours.size() < 2)
        throw InputError(
            "observer", "",
            fmt::format("needs at least 2 frames in each set, got {} real and {} rendered", real.size(), ours.size()));
    const std::size_t nr = real.size(), ns = ours.size(), n = nr + ns;
    constexpr std::size_t d = kScoredStatCount;
    Matrix X(n, std::vector<double>(d + 1, 0.0));
    std::vector<bool> anyNan(n, false);
    for (std::size_t j = 0; j < d; ++j) {
        std::vector<double> col;
        for (std::size_t i = 0; i < n; ++i) col.push_back(i < nr ? real[i].values[j] : ours[i - nr].values[j]);
        double med = percentile(col, 50);  // NaN left out
        if (std::isnan(med)) med = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const bool nan = std::isnan(col[i]);
            X[i][j] = nan ? med : col[i];
            anyNan[i] = anyNan[i] || nan;
        }
    }
    for (std::size_t i = 0; i < n; ++i) X[i][d] = anyNan[i] ? 1.0 : 0.0;
    const int g = groups > 0 ? groups : static_cast<int>(nr);
    const int ng = std::min<int>(g, static_cast<int>(ns));
    std::vector<int> group(n);
    for (std::size_t i = 0; i < nr; ++i) group[i] = static_cast<int>(i);
    for (std::size_t i = 0; i < ns; ++i)
        group[nr + i] = static_cast<int>(nr) + static_cast<int>(i * static_cast<std::size_t>(ng) / ns);
    std::vector<double> score(n, 0.0);
    for (int held = 0; held < static_cast<int>(nr) + ng; ++held) {
        std::vector<std::size_t> train;
        for (std::size_t i = 0; i < n; ++i)
            if (group[i] != held) train.push_back(i);
        // Standardised over the training frames (std with ddof 0, + 1e-9).
        std::vector<double> mu(d + 1, 0.0), sd(d + 1, 0.0);
        for (std::size_t j = 0; j <= d; ++j) {
            for (std::size_t i : train) mu[j] += X[i][j];
            mu[j] /= static_cast<double>(train.size());
            for (std::size_t i : train) sd[j] += (X[i][j] - mu[j]) * (X[i][j] - mu[j]);
            sd[j] = std::sqrt(sd[j] / static_cast<double>(train.size())) + 1e-9;
        }
        auto standard = [&](std::size_t i) {
            std::vector<double> v(d + 1);
            for (std::size_t j = 0; j <= d; ++j) v[j] = (X[i][j] - mu[j]) / sd[j];
            return v;
        };
        Matrix xt;
        std::vector<int> yt;
        std::vector<double> wt;
        std::size_t pos = 0;
        for (std::size_t i : train) pos += i < nr;
        const std::size_t neg = train.size() - pos;
        for (std::size_t i : train) {
            xt.push_back(standard(i));
            yt.push_back(i < nr ? 1 : -1);
            // class_weight='balanced': n / (2 n_class).
            wt.push_back(static_cast<double>(train.size()) / (2.0 * static_cast<double>(i < nr ? pos : neg)));
        }
        if (pos == 0 || neg == 0) continue;
        const LogisticModel m = fitLogistic(xt, yt, wt, 1.0);
        for (std::size_t i = 0; i < n; ++i)
            if (group[i] == held) score[i] = m.decision(standard(i));
    }
    ObserverResult r;
    r.realScores.assign(score.begin(), score.begin() + static_cast<std::ptrdiff_t>(nr));
    r.ourScores.assign(score.begin() + static_cast<std::ptrdiff_t>(nr), score.end());
    r.auc = rocAuc(r.realScores, r.ourScores);
    return r;
}

}  // namespace mucosa::tune
