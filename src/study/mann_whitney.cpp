#include <mucosa/study/stats.hpp>

#include <algorithm>
#include <cmath>

#include "ranks.hpp"

namespace mucosa::study {

std::optional<MannWhitneyResult> mannWhitney(std::span<const double> a, std::span<const double> b, std::string* why) {
    // Mann & Whitney 1947; asymptotic form as scipy.stats.mannwhitneyu (SciPy
    // 1.10): U = max(U1, U2), z = (U - n1 n2/2 - 0.5) / s,
    // s^2 = n1 n2 / 12 * ((n + 1) - sum(t^3 - t) / (n (n - 1))).
    if (a.empty() || b.empty()) {
        detail::setWhy(why, "one of the two samples is empty");
        return std::nullopt;
    }
    MannWhitneyResult r;
    r.n1 = static_cast<int>(a.size());
    r.n2 = static_cast<int>(b.size());
    std::vector<double> all(a.begin(), a.end());
    all.insert(all.end(), b.begin(), b.end());
    const std::vector<double> ranks = averageRanks(all);
    double r1 = 0;
    for (std::size_t i = 0; i < a.size(); ++i) r1 += ranks[i];
    const double n1 = r.n1, n2 = r.n2, n = n1 + n2;
    r.U = r1 - n1 * (n1 + 1) / 2;
    const double u2 = n1 * n2 - r.U;
    const double u = std::max(r.U, u2);
    std::sort(all.begin(), all.end());
    double tie = 0;
    detail::forEachTieGroup(all, [&](double t) { tie += t * t * t - t; });
    const double s = std::sqrt(n1 * n2 / 12 * ((n + 1) - tie / (n * (n - 1))));
    if (!(s > 0)) {
        // Every value tied: no evidence of a difference. SciPy's formula gives
        // z = -0.5 / 0 = -inf and clips p to 1; we report z = 0 and p = 1.
        r.z = 0;
        r.p = 1;
        return r;
    }
    r.z = (u - n1 * n2 / 2 - 0.5) / s;
    // 2 sf(z) with the sign kept: when U1 = U2 the continuity correction makes
    // z slightly negative and p clips to 1, as in SciPy.
    r.p = std::min(1.0, std::erfc(r.z / std::sqrt(2.0)));
    return r;
}

}  // namespace mucosa::study
