// The logistic observer (tune/observer.hpp) against scikit-learn: the same
// fit and the same cross-validated AUC as ../shared/realism/observer.py on
// statistics made up by a formula (no real frame is involved).
#include <mucosa/tune/observer.hpp>

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>

namespace {

using namespace mucosa;

// Frame i's statistic k; the rendered set's shifted by 0.12 cos(k / 2).
double value(int i, int k, bool rendered) {
    return std::sin(1.3 * i + 0.7 * k) + (rendered ? 0.12 * std::cos(0.5 * k) : 0.0) + 0.1 * k;
}

struct Sets {
    std::vector<tune::FrameStats> real, ours;
};
Sets madeUp() {
    Sets s;
    for (int i = 0; i < 28; ++i) {
        tune::FrameStats f;
        f.values.fill(std::numeric_limits<double>::quiet_NaN());  // the rings: not read
        for (int k = 0; k < tune::kScoredStatCount; ++k) f.values[static_cast<std::size_t>(k)] = value(i, k, i >= 12);
        (i < 12 ? s.real : s.ours).push_back(f);
    }
    s.real[3].values[12] = std::numeric_limits<double>::quiet_NaN();
    s.ours[5].values[14] = std::numeric_limits<double>::quiet_NaN();
    return s;
}

// What scikit-learn 1.2's LogisticRegression(C=1, class_weight='balanced')
// gives on these sets, held out as observer.py holds them out (printed to 8
// digits; solver newton-cg at tol 1e-14, so that both sides are at the
// optimum: observer.py's default lbfgs stops about 2e-5 short of it).
TEST(Observer, MatchesScikitLearnsLogisticObserver) {
    const Sets s = madeUp();
    const tune::ObserverResult r = tune::logisticObserver(s.real, s.ours);
    EXPECT_NEAR(r.auc, 0.859375, 1e-12);
    ASSERT_EQ(r.realScores.size(), 12u);
    ASSERT_EQ(r.ourScores.size(), 16u);
    EXPECT_NEAR(r.realScores.front(), 0.96963774, 1e-5);
    EXPECT_NEAR(r.ourScores.back(), -1.1461208, 1e-5);
    // Four groups of rendered frames: the last group's model saw 12 of them.
    const tune::ObserverResult g4 = tune::logisticObserver(s.real, s.ours, 4);
    EXPECT_NEAR(g4.auc, 0.859375, 1e-12);
    EXPECT_NEAR(g4.ourScores.back(), -1.2246155, 1e-5);
}

TEST(Observer, TheFitIsScikitLearnsOnAllFrames) {
    // All 28 frames, NaN imputed and standardised as observer.py does, one fit.
    const Sets s = madeUp();
    std::vector<std::vector<double>> x;
    std::vector<int> y;
    std::vector<double> w;
    for (int i = 0; i < 28; ++i) {
        const tune::FrameStats& f =
            i < 12 ? s.real[static_cast<std::size_t>(i)] : s.ours[static_cast<std::size_t>(i - 12)];
        x.emplace_back(f.values.begin(), f.values.begin() + tune::kScoredStatCount);
        y.push_back(i < 12 ? 1 : -1);
        w.push_back(28.0 / (2.0 * (i < 12 ? 12 : 16)));
    }
    // Column medians for the two NaN, the indicator column, standardisation.
    for (auto [row, col] : {std::pair{3, 12}, std::pair{17, 14}}) {
        std::vector<double> c;
        for (int i = 0; i < 28; ++i)
            if (i != row) c.push_back(x[static_cast<std::size_t>(i)][static_cast<std::size_t>(col)]);
        x[static_cast<std::size_t>(row)][static_cast<std::size_t>(col)] = tune::percentile(c, 50);
    }
    for (int i = 0; i < 28; ++i) x[static_cast<std::size_t>(i)].push_back(i == 3 || i == 17 ? 1.0 : 0.0);
    for (std::size_t j = 0; j < x[0].size(); ++j) {
        double mu = 0, sd = 0;
        for (const auto& r : x) mu += r[j];
        mu /= 28;
        for (const auto& r : x) sd += (r[j] - mu) * (r[j] - mu);
        sd = std::sqrt(sd / 28) + 1e-9;
        for (auto& r : x) r[j] = (r[j] - mu) / sd;
    }
    const tune::LogisticModel m = tune::fitLogistic(x, y, w);
    const double sk[] = {-0.72083553, -0.582654, -0.31940903, 0.00088289301, 0.31982215};
    for (std::size_t j = 0; j < 5; ++j) EXPECT_NEAR(m.w[j], sk[j], 2e-6) << j;
    EXPECT_NEAR(m.b, -0.12700611, 1e-6);
}

TEST(Observer, IdenticalSetsCannotBeToldApartAndTooFewFramesAreRefused) {
    const Sets s = madeUp();
    // The real set against itself, shuffled into the other role: no
    // systematic difference, so held-out scores sit about chance.
    const tune::ObserverResult same = tune::logisticObserver(s.real, s.real);
    EXPECT_LT(same.auc, 0.75);
    EXPECT_DOUBLE_EQ(tune::rocAuc({1, 2}, {2, 0}), 0.625);  // (0.5 + 1 + 1 + 0) / 4: ties count half
    EXPECT_THROW(tune::logisticObserver({s.real[0]}, s.ours), InputError);
}

}  // namespace
