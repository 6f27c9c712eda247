// Small hand-checkable properties of the statistics; the systematic comparison
// with SciPy is tests/study/scipy_crosscheck.py.
#include <cmath>

#include <gtest/gtest.h>

#include <mucosa/study/stats.hpp>

namespace mucosa::study {
namespace {

TEST(studyStats, AverageRanksShareTies) {
    const std::vector<double> v{3, 1, 3, 2, 3};
    EXPECT_EQ(averageRanks(v), (std::vector<double>{4, 1, 4, 2, 4}));
}

TEST(studyStats, WilcoxonExactAllPositiveFive) {
    // n = 5, all differences positive, no ties: P(W+ = 15) = 1/32, two-sided 1/16.
    const std::vector<double> x{1.1, 2.2, 3.3, 4.4, 5.5}, y{0, 0, 0, 0, 0};
    const auto w = wilcoxonSignedRank(x, y);
    ASSERT_TRUE(w);
    EXPECT_EQ(w->T, 0);
    EXPECT_EQ(w->wPlus, 15);
    ASSERT_TRUE(w->pExact);
    EXPECT_DOUBLE_EQ(*w->pExact, 0.0625);
}

TEST(studyStats, WilcoxonDropsZerosAndReportsNoExactWithTies) {
    const std::vector<double> x{1, 2, 3, 4, 5}, y{1, 1, 1, 1, 1};  // one zero
    const auto w = wilcoxonSignedRank(x, y);
    ASSERT_TRUE(w);
    EXPECT_EQ(w->n, 4);
    EXPECT_EQ(w->nZero, 1);
    EXPECT_FALSE(w->pExact);
}

TEST(studyStats, WilcoxonAllZeroIsUndefinedNotZero) {
    const std::vector<double> x{2, 2, 2}, y{2, 2, 2};
    std::string why;
    EXPECT_FALSE(wilcoxonSignedRank(x, y, &why));
    EXPECT_NE(why.find("zero"), std::string::npos);
}

TEST(studyStats, FriedmanAllTiedIsUndefined) {
    std::string why;
    EXPECT_FALSE(friedman({{3, 3, 3}, {2, 2, 2}}, &why));
    EXPECT_FALSE(why.empty());
    EXPECT_FALSE(friedman({{1, 2}, {1, 2}}, &why));  // k = 2: as SciPy, needs 3 treatments
}

TEST(studyStats, FriedmanPerfectAgreementGivesKendallW1) {
    const auto f = friedman({{1, 2, 3, 4}, {1, 2, 3, 4}, {1.5, 2.5, 3.5, 4.5}});
    ASSERT_TRUE(f);
    EXPECT_NEAR(f->kendallsW, 1.0, 1e-12);
    EXPECT_NEAR(f->chi2, 9.0, 1e-12);  // n (k - 1)
}

TEST(studyStats, RocRunsFromOriginToOneOneAndAucIsMannWhitney) {
    const std::vector<int> pos{1, 2, 2, 3, 5}, neg{3, 4, 4, 5, 5, 2};
    const RocResult r = roc(pos, neg);
    ASSERT_EQ(r.points.size(), 6u);
    EXPECT_EQ(r.points.front(), (std::array<double, 2>{0, 0}));
    EXPECT_EQ(r.points.back(), (std::array<double, 2>{1, 1}));
    double wins = 0;  // P(pos < neg) + P(tie) / 2
    for (int p : pos)
        for (int n : neg) wins += p < n ? 1 : p == n ? 0.5 : 0;
    EXPECT_NEAR(r.auc, wins / static_cast<double>(pos.size() * neg.size()), 1e-15);
}

TEST(studyStats, BinomialTwoSidedIsTwiceTheSmallTail) {
    const BinomialResult b = binomialTest(8, 10);
    EXPECT_NEAR(b.p, 2.0 * (1 + 10 + 45) / 1024, 1e-15);
    EXPECT_DOUBLE_EQ(binomialTest(5, 10).p, 1.0);
    EXPECT_LT(b.ciLow, 0.8);
    EXPECT_GT(b.ciHigh, 0.8);
    EXPECT_EQ(binomialTest(0, 7).ciLow, 0.0);
    EXPECT_EQ(binomialTest(7, 7).ciHigh, 1.0);
}

TEST(studyStats, MannWhitneyAllTiedGivesPOneAndEmptyIsUndefined) {
    const std::vector<double> a{3, 3}, b{3, 3, 3};
    const auto m = mannWhitney(a, b);  // as scipy.stats.mannwhitneyu: U = n1 n2 / 2, p = 1
    ASSERT_TRUE(m);
    EXPECT_EQ(m->U, 3.0);
    EXPECT_EQ(m->p, 1.0);
    EXPECT_FALSE(mannWhitney(a, {}));
}

}  // namespace
}  // namespace mucosa::study
