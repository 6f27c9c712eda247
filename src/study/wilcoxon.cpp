#include <mucosa/study/stats.hpp>

#include <algorithm>
#include <cmath>

#include "ranks.hpp"

namespace mucosa::study {

namespace {

// Two-sided normal tail 2 * sf(|z|), as scipy's 2 * norm.sf(abs(z)); erfc keeps
// relative accuracy far into the tail (p ~ 1e-200 is common for big studies).
double twoSidedNormalP(double z) {
    return std::min(1.0, std::erfc(std::fabs(z) / std::sqrt(2.0)));
}

}  // namespace

std::optional<WilcoxonResult> wilcoxonSignedRank(std::span<const double> x, std::span<const double> y,
                                                 std::string* why) {
    // Wilcoxon 1945; variance with ties as scipy.stats.wilcoxon (SciPy 1.10,
    // method='approx'): var = [n(n+1)(2n+1) - sum t(t^2-1)/2] / 24.
    WilcoxonResult r;
    r.nPairs = static_cast<int>(x.size());
    std::vector<double> d;
    d.reserve(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double di = x[i] - y[i];
        if (di == 0) {
            ++r.nZero;
        } else {
            d.push_back(di);
        }
    }
    r.n = static_cast<int>(d.size());
    if (r.n == 0) {
        detail::setWhy(why, x.empty() ? "no observer rated both categories" : "every difference is zero");
        return std::nullopt;
    }
    std::vector<double> absd(d.size());
    for (std::size_t i = 0; i < d.size(); ++i) absd[i] = std::fabs(d[i]);
    const std::vector<double> ranks = averageRanks(absd);
    for (std::size_t i = 0; i < d.size(); ++i) (d[i] > 0 ? r.wPlus : r.wMinus) += ranks[i];
    r.T = std::min(r.wPlus, r.wMinus);
    const double n = static_cast<double>(r.n);
    const double mn = n * (n + 1) * 0.25;
    double se = n * (n + 1) * (2 * n + 1);
    std::vector<double> sorted(absd);
    std::sort(sorted.begin(), sorted.end());
    bool tied = false;
    detail::forEachTieGroup(sorted, [&](double t) {
        se -= 0.5 * (t * (t * t - 1));
        tied = true;
    });
    se = std::sqrt(se / 24);
    r.z = (r.T - mn) / se;
    r.p = twoSidedNormalP(r.z);
    if (!tied && r.nZero == 0) {
        // Exact null distribution of W+ (all 2^n sign patterns equally likely),
        // built as probabilities so n in the hundreds does not overflow.
        const int maxW = r.n * (r.n + 1) / 2;
        std::vector<double> pdf(static_cast<std::size_t>(maxW) + 1, 0.0);
        pdf[0] = 1.0;
        int reach = 0;
        for (int i = 1; i <= r.n; ++i) {
            reach += i;
            for (int w = reach; w >= 0; --w)
                pdf[static_cast<std::size_t>(w)] =
                    0.5 * (pdf[static_cast<std::size_t>(w)] + (w >= i ? pdf[static_cast<std::size_t>(w - i)] : 0.0));
        }
        const int wp = static_cast<int>(std::lround(r.wPlus));
        double pLess = 0, pGreater = 0;
        for (int w = 0; w <= maxW; ++w) {
            if (w <= wp) pLess += pdf[static_cast<std::size_t>(w)];
            if (w >= wp) pGreater += pdf[static_cast<std::size_t>(w)];
        }
        r.pExact = std::min(1.0, 2 * std::min(pLess, pGreater));
    }
    return r;
}

}  // namespace mucosa::study
