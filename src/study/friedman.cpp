#include <mucosa/study/stats.hpp>

#include <algorithm>
#include <cmath>

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/special_functions/gamma.hpp>

#include "ranks.hpp"

namespace mucosa::study {

namespace {

// ln Q(a, x), the regularised upper incomplete gamma, in log space so that
// chi-squared tails far below the smallest double (p ~ 1e-330 for a large
// study) still have a value. Continued fraction (modified Lentz; Numerical
// Recipes 3rd ed., 6.2.7) for x > a + 1, Boost's gamma_q otherwise.
double lnGammaQ(double a, double x) {
    if (x <= a + 1) return std::log(boost::math::gamma_q(a, x));
    constexpr double kTiny = 1e-300;
    double b = x + 1 - a, c = 1 / kTiny, d = 1 / b, h = d;
    for (int i = 1; i < 10000; ++i) {
        const double an = -i * (i - a);
        b += 2;
        d = an * d + b;
        if (std::fabs(d) < kTiny) d = kTiny;
        c = b + an / c;
        if (std::fabs(c) < kTiny) c = kTiny;
        d = 1 / d;
        const double delta = d * c;
        h *= delta;
        if (std::fabs(delta - 1) < 1e-16) break;
    }
    return -x + a * std::log(x) - std::lgamma(a) + std::log(h);
}

}  // namespace

std::optional<FriedmanResult> friedman(const std::vector<std::vector<double>>& blocks, std::string* why) {
    // Friedman 1937; tie correction as scipy.stats.friedmanchisquare (SciPy 1.10):
    // chi2 = [12/(n k (k+1)) sum_j R_j^2 - 3 n (k+1)] / [1 - sum (t^3 - t) / (n k (k^2 - 1))].
    if (blocks.empty()) {
        detail::setWhy(why, "no observer rated every category");
        return std::nullopt;
    }
    const std::size_t k = blocks.front().size();
    if (k < 3) {
        detail::setWhy(why, "needs at least 3 categories");
        return std::nullopt;
    }
    FriedmanResult r;
    r.nBlocks = static_cast<int>(blocks.size());
    r.k = static_cast<int>(k);
    r.df = r.k - 1;
    r.rankSums.assign(k, 0.0);
    double ties = 0;
    for (const auto& row : blocks) {
        const std::vector<double> ranks = averageRanks(row);
        for (std::size_t j = 0; j < k; ++j) r.rankSums[j] += ranks[j];
        std::vector<double> sorted(row);
        std::sort(sorted.begin(), sorted.end());
        detail::forEachTieGroup(sorted, [&](double t) { ties += t * (t * t - 1); });
    }
    const double n = static_cast<double>(r.nBlocks), kd = static_cast<double>(k);
    double ssbn = 0;
    for (double s : r.rankSums) ssbn += s * s;
    r.tieCorrection = 1.0 - ties / (kd * (kd * kd - 1) * n);
    if (r.tieCorrection <= 0) {
        detail::setWhy(why, "every observer gave all categories the same value");
        return std::nullopt;
    }
    r.chi2Uncorrected = 12.0 / (kd * n * (kd + 1)) * ssbn - 3 * n * (kd + 1);
    r.chi2 = r.chi2Uncorrected / r.tieCorrection;
    const boost::math::chi_squared dist(static_cast<double>(r.df));
    r.p = boost::math::cdf(boost::math::complement(dist, std::max(0.0, r.chi2)));
    r.lnP = r.p > 1e-300 ? std::log(r.p) : lnGammaQ(r.df / 2.0, r.chi2 / 2);
    r.kendallsW = r.chi2 / (n * (kd - 1));
    return r;
}

}  // namespace mucosa::study
