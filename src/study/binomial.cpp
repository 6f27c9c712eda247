#include <mucosa/study/stats.hpp>

#include <algorithm>
#include <cmath>

#include <boost/math/distributions/binomial.hpp>
#include <boost/math/distributions/normal.hpp>

#include "ranks.hpp"

namespace mucosa::study {

BinomialResult binomialTest(int k, int n, double confidence) {
    BinomialResult r;
    r.n = n;
    r.k = k;
    if (n <= 0) return r;
    r.proportion = static_cast<double>(k) / n;
    // Against 1/2 the distribution is symmetric, so scipy.stats.binomtest's
    // "as or less likely" two-sided p is twice the smaller tail, capped at 1.
    const boost::math::binomial dist(static_cast<double>(n), 0.5);
    const int lo = std::min(k, n - k);
    r.p = 2 * k == n ? 1.0 : std::min(1.0, 2 * boost::math::cdf(dist, static_cast<double>(lo)));
    // Wilson 1927 score interval, as scipy's _binom_wilson_conf_int(correction=False).
    const double z = boost::math::quantile(boost::math::normal(), 0.5 + 0.5 * confidence);
    const double nd = n, p = r.proportion, q = 1 - p;
    const double denom = 2 * (nd + z * z);
    const double center = (2 * nd * p + z * z) / denom;
    const double dlo = z * std::sqrt(z * z + 4 * nd * p * q) / denom;
    r.ciLow = k == 0 ? 0.0 : center - dlo;
    r.ciHigh = k == n ? 1.0 : center + dlo;
    return r;
}

}  // namespace mucosa::study
