#pragma once
// The statistics of the paper's user study, each checked against SciPy
// (tests/study). Every function names its source and the SciPy call it agrees
// with; inputs are plain numbers so they can be tested on hand-made data.
#include <array>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace mucosa::study {

// Friedman 1937 with the tie correction, as scipy.stats.friedmanchisquare:
// blocks[i][j] = value of block i under treatment j.
struct FriedmanResult {
    int nBlocks = 0, k = 0, df = 0;
    double chi2 = 0, chi2Uncorrected = 0, tieCorrection = 1, p = 1;
    double lnP = 0;        // ln p, finite even where p underflows to 0
    double kendallsW = 0;  // Kendall & Babington Smith 1939: W = chi2 / (n (k - 1))
    std::vector<double> rankSums;
};
// nullopt (with `why`) when the statistic is undefined: fewer than 3
// treatments, no blocks, or every block tied throughout.
std::optional<FriedmanResult> friedman(const std::vector<std::vector<double>>& blocks, std::string* why = nullptr);

// Wilcoxon 1945 signed-rank test of paired x, y (d = x - y), zeros dropped
// (zero_method='wilcox'), normal approximation with the tie-corrected variance
// and no continuity correction, two-sided: scipy.stats.wilcoxon(x, y,
// zero_method='wilcox', correction=False, method='approx'). `pExact` only when
// no d is zero and no |d| is tied (scipy method='exact').
struct WilcoxonResult {
    int nPairs = 0, n = 0, nZero = 0;
    double wPlus = 0, wMinus = 0, T = 0, z = 0, p = 1;
    std::optional<double> pExact;
};
std::optional<WilcoxonResult> wilcoxonSignedRank(std::span<const double> x, std::span<const double> y,
                                                 std::string* why = nullptr);

// Mann & Whitney 1947, U of the first sample, two-sided normal approximation
// with tie correction and continuity correction: scipy.stats.mannwhitneyu(a, b,
// alternative='two-sided', method='asymptotic', use_continuity=True). When
// every value is tied: U = n1 n2 / 2, z = 0, p = 1 (SciPy: p = 1 too).
struct MannWhitneyResult {
    int n1 = 0, n2 = 0;
    double U = 0, z = 0, p = 1;
};
std::optional<MannWhitneyResult> mannWhitney(std::span<const double> a, std::span<const double> b,
                                             std::string* why = nullptr);

// Empirical ROC of Likert scores (the paper's Fig. 7): "synthetic if score <= t"
// for t = 0..5; positives are a synthetic category's scores, negatives the real
// frames' scores. AUC by the trapezoid rule = P(pos < neg) + P(pos = neg) / 2
// (Bamber 1975).
struct RocResult {
    int nPos = 0, nNeg = 0;
    std::vector<std::array<double, 2>> points;  // [fpr, tpr], t = 0..5
    double auc = 0;
};
RocResult roc(std::span<const int> positives, std::span<const int> negatives);

// Exact two-sided binomial test against 1/2 (scipy.stats.binomtest(k, n, 0.5))
// and the Wilson 1927 score interval without continuity correction
// (binomtest(...).proportion_ci(0.95, method='wilson')).
struct BinomialResult {
    int n = 0, k = 0;
    double proportion = 0, p = 1, ciLow = 0, ciHigh = 1;
};
BinomialResult binomialTest(int k, int n, double confidence = 0.95);

// Average ranks (1-based) with ties sharing their mean rank, as
// scipy.stats.rankdata(method='average').
std::vector<double> averageRanks(std::span<const double> values);

}  // namespace mucosa::study
