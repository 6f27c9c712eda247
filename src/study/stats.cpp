#include <mucosa/study/stats.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

#include <boost/math/distributions/binomial.hpp>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/special_functions/gamma.hpp>

namespace mucosa::study {

namespace {

void setWhy(std::string* why, const std::string& text) {
    if (why) *why = text;
}

// Two-sided normal tail 2 * sf(|z|), as scipy's 2 * norm.sf(abs(z)); erfc keeps
// relative accuracy far into the tail (p ~ 1e-200 is common for big studies).
double twoSidedNormalP(double z) { return std::min(1.0, std::erfc(std::fabs(z) / std::sqrt(2.0))); }

// Sizes of groups of equal values among sorted values (only groups > 1 matter).
template <class F>
void forEachTieGroup(const std::vector<double>& sorted, F&& f) {
    std::size_t i = 0;
    while (i < sorted.size()) {
        std::size_t j = i + 1;
        while (j < sorted.size() && sorted[j] == sorted[i]) ++j;
        if (j - i > 1) f(static_cast<double>(j - i));
        i = j;
    }
}

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

std::vector<double> averageRanks(std::span<const double> values) {
    const std::size_t n = values.size();
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return values[a] < values[b]; });
    std::vector<double> ranks(n);
    std::size_t i = 0;
    while (i < n) {
        std::size_t j = i + 1;
        while (j < n && values[order[j]] == values[order[i]]) ++j;
        // Ranks i+1..j share their mean (i + 1 + j) / 2.
        const double r = 0.5 * static_cast<double>(i + 1 + j);
        for (std::size_t m = i; m < j; ++m) ranks[order[m]] = r;
        i = j;
    }
    return ranks;
}

std::optional<FriedmanResult> friedman(const std::vector<std::vector<double>>& blocks, std::string* why) {
    // Friedman 1937; tie correction as scipy.stats.friedmanchisquare (SciPy 1.10):
    // chi2 = [12/(n k (k+1)) sum_j R_j^2 - 3 n (k+1)] / [1 - sum (t^3 - t) / (n k (k^2 - 1))].
    if (blocks.empty()) {
        setWhy(why, "no observer rated every category");
        return std::nullopt;
    }
    const std::size_t k = blocks.front().size();
    if (k < 3) {
        setWhy(why, "needs at least 3 categories");
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
        forEachTieGroup(sorted, [&](double t) { ties += t * (t * t - 1); });
    }
    const double n = static_cast<double>(r.nBlocks), kd = static_cast<double>(k);
    double ssbn = 0;
    for (double s : r.rankSums) ssbn += s * s;
    r.tieCorrection = 1.0 - ties / (kd * (kd * kd - 1) * n);
    if (r.tieCorrection <= 0) {
        setWhy(why, "every observer gave all categories the same value");
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
        setWhy(why, x.empty() ? "no observer rated both categories" : "every difference is zero");
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
    forEachTieGroup(sorted, [&](double t) {
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

std::optional<MannWhitneyResult> mannWhitney(std::span<const double> a, std::span<const double> b, std::string* why) {
    // Mann & Whitney 1947; asymptotic form as scipy.stats.mannwhitneyu (SciPy
    // 1.10): U = max(U1, U2), z = (U - n1 n2/2 - 0.5) / s,
    // s^2 = n1 n2 / 12 * ((n + 1) - sum(t^3 - t) / (n (n - 1))).
    if (a.empty() || b.empty()) {
        setWhy(why, "one of the two samples is empty");
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
    forEachTieGroup(all, [&](double t) { tie += t * t * t - t; });
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

RocResult roc(std::span<const int> positives, std::span<const int> negatives) {
    RocResult r;
    r.nPos = static_cast<int>(positives.size());
    r.nNeg = static_cast<int>(negatives.size());
    std::array<int, 7> pos{}, neg{};  // counts per score 0..6 (scores are 1..5)
    for (int s : positives) ++pos[static_cast<std::size_t>(std::clamp(s, 0, 6))];
    for (int s : negatives) ++neg[static_cast<std::size_t>(std::clamp(s, 0, 6))];
    int cp = 0, cn = 0;
    for (int t = 0; t <= 5; ++t) {
        cp += pos[static_cast<std::size_t>(t)];
        cn += neg[static_cast<std::size_t>(t)];
        r.points.push_back({r.nNeg ? static_cast<double>(cn) / r.nNeg : 0.0,
                            r.nPos ? static_cast<double>(cp) / r.nPos : 0.0});
    }
    for (std::size_t i = 1; i < r.points.size(); ++i)
        r.auc += (r.points[i][0] - r.points[i - 1][0]) * (r.points[i][1] + r.points[i - 1][1]) / 2;
    return r;
}

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
