// The analysis of tests/data/study/ratings_A_main.csv against the
// SciPy 1.10 / R 4.2 results stored beside it (expected_A_main.json, whose
// "conventions" give the exact calls). Statistics to 1e-9, p-values to 1e-6
// relative.
#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/study/analysis.hpp>

#include "test_support.hpp"

namespace mucosa::study {
namespace {

using nlohmann::json;

constexpr double kStatTol = 1e-9;
constexpr double kPRelTol = 1e-6;

void expectP(double expected, double actual, const std::string& what) {
    EXPECT_NEAR(actual, expected, kPRelTol * std::fabs(expected)) << what;
}

class studyExpectedA : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        std::ifstream in(test::testdata("study/expected_A_main.json"));
        expected_ = json::parse(in);
        StudyData d;
        d.ratings = readRatingsCsv(test::testdata("study/ratings_A_main.csv"));
        analysis_ = analyze(d);
    }
    static const GroupAnalysis& group(const std::string& g) {
        for (const auto& ga : analysis_.groups)
            if (ga.group == g) return ga;
        throw std::runtime_error("no group " + g);
    }
    static json expected_;
    static Analysis analysis_;
};
json studyExpectedA::expected_;
Analysis studyExpectedA::analysis_;

const char* const kGroupNames[] = {"all", "naive", "expert"};

TEST_F(studyExpectedA, StudyObserversAndGroupsMatch) {
    ASSERT_EQ(analysis_.groups.size(), 3u);
    for (const char* g : kGroupNames) EXPECT_EQ(json(group(g).observers), expected_["observers"][g]) << g;
    EXPECT_TRUE(analysis_.warnings.empty());
}

TEST_F(studyExpectedA, StudyDescriptivesMatchNumpy) {
    // numpy: x.mean(), x.std(ddof=1), len(x), number of observers with ratings.
    for (const char* g : kGroupNames)
        for (int c = 1; c <= 5; ++c) {
            const json& e = expected_["descriptives"][g][std::to_string(c)];
            const CategoryStats& s = group(g).categories.at(c);
            EXPECT_EQ(s.nRatings, e["n_ratings"].get<int>());
            EXPECT_EQ(s.nObservers, e["n_observers"].get<int>());
            EXPECT_NEAR(s.mean, e["mean"].get<double>(), kStatTol);
            ASSERT_TRUE(s.sd);
            EXPECT_NEAR(*s.sd, e["sd_ddof1"].get<double>(), kStatTol);
        }
}

TEST_F(studyExpectedA, StudyFriedmanMatchesScipy) {
    // scipy.stats.friedmanchisquare(*columns of observer means)
    for (const char* g : kGroupNames) {
        const json& e = expected_["friedman_observer_means"][g];
        ASSERT_TRUE(group(g).friedman.result) << g;
        const FriedmanResult& f = *group(g).friedman.result;
        EXPECT_EQ(f.nBlocks, e["n_blocks"].get<int>());
        EXPECT_EQ(f.df, e["df"].get<int>());
        EXPECT_NEAR(f.chi2, e["statistic"].get<double>(), kStatTol) << g;
        EXPECT_NEAR(f.chi2Uncorrected, e["statistic_uncorrected"].get<double>(), kStatTol) << g;
        EXPECT_NEAR(f.tieCorrection, e["tie_correction_factor"].get<double>(), kStatTol) << g;
        EXPECT_NEAR(f.kendallsW, e["kendalls_W"].get<double>(), kStatTol) << g;
        expectP(e["pvalue"].get<double>(), f.p, std::string("friedman p ") + g);
        EXPECT_NEAR(f.lnP, e["ln_pvalue"].get<double>(), 1e-9 * std::fabs(e["ln_pvalue"].get<double>()));
        for (std::size_t j = 0; j < 5; ++j) EXPECT_DOUBLE_EQ(f.rankSums[j], e["rank_sums"][j].get<double>());
        // The blocks themselves: observer means, row by row.
        const auto& m = e["observer_means_matrix"];
        ASSERT_EQ(group(g).observerMeans.size(), m.size());
        for (std::size_t i = 0; i < m.size(); ++i)
            for (std::size_t j = 0; j < 5; ++j) EXPECT_NEAR(group(g).observerMeans[i][j], m[i][j].get<double>(), 1e-12);
    }
}

TEST_F(studyExpectedA, StudyFriedmanOnViewBlocksMatchesScipy) {
    // The function itself on the other blocking of the same data: blocks =
    // (observer, patient, pose), value = raw score (heavy ties: k = 5 scores of 1-5).
    StudyData d;
    std::ifstream in(test::testdata("study/ratings_A_main.csv"));
    std::string line;
    std::getline(in, line);
    std::map<std::string, std::array<double, 5>> blocks;
    std::map<std::string, std::string> groupOf;
    while (std::getline(in, line)) {
        std::vector<std::string> f;
        std::stringstream ss(line);
        std::string x;
        while (std::getline(ss, x, ',')) f.push_back(x);
        const std::string key = f[0] + "|" + f[4] + "|" + f[5];
        blocks[key][std::stoul(f[2]) - 1] = std::stod(f[6]);
        groupOf[key] = f[1];
    }
    for (const char* g : kGroupNames) {
        std::vector<std::vector<double>> rows;
        for (const auto& [k, v] : blocks)
            if (std::string(g) == "all" || groupOf[k] == g) rows.emplace_back(v.begin(), v.end());
        const auto f = friedman(rows);
        const json& e = expected_["friedman_view_blocks"][g];
        ASSERT_TRUE(f);
        EXPECT_EQ(f->nBlocks, e["n_blocks"].get<int>());
        EXPECT_NEAR(f->chi2, e["statistic"].get<double>(), kStatTol * 1e2) << g;  // |chi2| ~ 1e3: 1e-12 relative
        EXPECT_NEAR(f->kendallsW, e["kendalls_W"].get<double>(), kStatTol) << g;
        if (e["pvalue"].get<double>() > 0) {
            expectP(e["pvalue"].get<double>(), f->p, std::string("view-block friedman p ") + g);
        } else {
            // SciPy underflows to 0; we report the tail (ln p agrees).
            EXPECT_NEAR(f->lnP, e["ln_pvalue"].get<double>(), 1e-6 * std::fabs(e["ln_pvalue"].get<double>()));
        }
    }
}

TEST_F(studyExpectedA, StudyWilcoxonMatchesScipy) {
    // scipy.stats.wilcoxon(x, y, zero_method='wilcox', correction=False, method='approx')
    for (const char* g : kGroupNames)
        for (int c = 1; c <= 4; ++c) {
            const json& e = expected_["wilcoxon_observer_means"][g][fmt::format("c{}_vs_c5", c)];
            const auto& o = group(g).wilcoxon.at(c);
            ASSERT_TRUE(o.result) << g << c;
            const WilcoxonResult& w = *o.result;
            const json& t = e["tests"]["wilcox_approx"];
            EXPECT_EQ(w.n, e["n_nonzero"].get<int>());
            EXPECT_EQ(w.nZero, e["n_zero"].get<int>());
            EXPECT_NEAR(w.wPlus, e["W_plus"].get<double>(), kStatTol);
            EXPECT_NEAR(w.wMinus, e["W_minus"].get<double>(), kStatTol);
            EXPECT_NEAR(w.T, t["statistic_T_min"].get<double>(), kStatTol);
            EXPECT_NEAR(w.z, t["z"].get<double>(), kStatTol) << g << c;
            expectP(t["pvalue"].get<double>(), w.p, fmt::format("wilcoxon p {} {}", g, c));
            EXPECT_EQ(w.pExact.has_value(), !e["tests"]["exact"].contains("not_applicable"));
        }
}

TEST_F(studyExpectedA, StudyRocAndAucMatchExpected) {
    for (const char* g : kGroupNames)
        for (int c = 1; c <= 4; ++c) {
            const json& e = expected_["roc"][g][fmt::format("c{}_vs_c5", c)];
            const RocResult& r = group(g).roc.at(c);
            EXPECT_EQ(r.nPos, e["n_pos"].get<int>());
            EXPECT_EQ(r.nNeg, e["n_neg"].get<int>());
            const json& pts = e["low_score_positive"]["points"];
            ASSERT_EQ(r.points.size(), pts.size());
            for (std::size_t i = 0; i < pts.size(); ++i) {
                EXPECT_NEAR(r.points[i][0], pts[i]["fpr"].get<double>(), kStatTol);
                EXPECT_NEAR(r.points[i][1], pts[i]["tpr"].get<double>(), kStatTol);
            }
            EXPECT_NEAR(r.auc, e["low_score_positive"]["auc_trapezoid"].get<double>(), kStatTol);
            EXPECT_NEAR(r.auc, e["low_score_positive"]["auc_mann_whitney"].get<double>(), kStatTol);
        }
}

TEST_F(studyExpectedA, StudyPerObserverAucMatchesExpected) {
    for (const char* g : kGroupNames)
        for (int c = 1; c <= 4; ++c) {
            const json& e = expected_["per_observer_auc_low_score_positive"][g][fmt::format("c{}_vs_c5", c)];
            const ObserverAuc& a = group(g).observerAuc.at(c);
            ASSERT_EQ(a.values.size(), e["per_observer"].size());
            for (std::size_t i = 0; i < a.values.size(); ++i)
                EXPECT_NEAR(a.values[i].value(), e["per_observer"][i].get<double>(), kStatTol);
            EXPECT_NEAR(a.mean.value(), e["mean"].get<double>(), kStatTol);
            EXPECT_NEAR(a.sd.value(), e["sd_ddof1"].get<double>(), kStatTol);
        }
}

TEST_F(studyExpectedA, StudyMannWhitneyMatchesScipyOnRocSamples) {
    // scipy.stats.mannwhitneyu(pos, neg, alternative='two-sided', method='asymptotic', use_continuity=True)
    const auto ratings = readRatingsCsv(test::testdata("study/ratings_A_main.csv"));
    for (const char* g : kGroupNames)
        for (int c = 1; c <= 4; ++c) {
            std::vector<double> pos, neg;
            for (const auto& r : ratings) {
                if (std::string(g) != "all" && r.group != g) continue;
                if (r.category == c) pos.push_back(r.score);
                if (r.category == 5) neg.push_back(r.score);
            }
            const json& e = expected_["roc"][g][fmt::format("c{}_vs_c5", c)]["mannwhitneyu"];
            const auto m = mannWhitney(pos, neg);
            ASSERT_TRUE(m);
            EXPECT_NEAR(m->U, e["U_pos"].get<double>(), kStatTol);
            EXPECT_NEAR(std::fabs(m->z), e["z_abs_continuity_corrected"].get<double>(), kStatTol);
            expectP(e["pvalue"].get<double>(), m->p, "mann-whitney p");
        }
}

TEST_F(studyExpectedA, StudyAgreesWithR) {
    // R 4.2.2 rows of the same file (crosscheck.R): friedman.test on observer
    // means; wilcox.test(x, y, paired=TRUE, exact=FALSE, correct=FALSE), whose
    // statistic V is W+; wilcox.test(pos, neg, exact=FALSE, correct=TRUE), W = U of pos.
    const auto ratings = readRatingsCsv(test::testdata("study/ratings_A_main.csv"));
    int checked = 0;
    for (const json& row : expected_["R_crosscheck"]["rows"]) {
        const std::string g = row["group"], test = row["test"], variant = row["variant"], cmp = row["comparison"];
        const double rStat = row["R_statistic"], rP = row["R_pvalue"];
        if (test == "friedman_observer_means") {
            const FriedmanResult& f = *group(g).friedman.result;
            EXPECT_NEAR(f.chi2, rStat, kStatTol);
            expectP(rP, f.p, "R friedman " + g);
            ++checked;
        } else if (test == "wilcoxon_observer_means" && variant == "wilcox_approx") {
            const WilcoxonResult& w = *group(g).wilcoxon.at(cmp[1] - '0').result;
            EXPECT_NEAR(w.wPlus, rStat, kStatTol);
            expectP(rP, w.p, "R wilcoxon " + g + " " + cmp);
            ++checked;
        } else if (test == "mann_whitney") {
            const int c = cmp[1] - '0';
            std::vector<double> pos, neg;
            for (const auto& r : ratings) {
                if (g != "all" && r.group != g) continue;
                if (r.category == c) pos.push_back(r.score);
                if (r.category == 5) neg.push_back(r.score);
            }
            const auto m = mannWhitney(pos, neg);
            EXPECT_NEAR(m->U, rStat, kStatTol);
            expectP(rP, m->p, "R mann-whitney " + g + " " + cmp);
            ++checked;
        }
    }
    EXPECT_EQ(checked, 3 + 12 + 12);
}

TEST_F(studyExpectedA, StudyStatsJsonHasTheDocumentedFields) {
    const json j = json::parse(statsJson(analysis_, "ratings_A_main.csv"));
    for (const char* g : kGroupNames) {
        const json& G = j.at(g);
        for (const char* k : {"n_ratings", "mean", "sd", "n_observers"}) EXPECT_TRUE(G["categories"]["3"].contains(k));
        for (const char* k : {"chi2", "df", "p", "n_blocks", "kendalls_w"}) EXPECT_TRUE(G["friedman"].contains(k));
        for (const char* k : {"T", "z", "p", "n"}) EXPECT_TRUE(G["wilcoxon"]["4"].contains(k));
        EXPECT_FALSE(G["wilcoxon"].contains("5"));
        EXPECT_EQ(G["roc"]["1"]["points"].size(), 6u);
        EXPECT_EQ(G["roc"]["1"]["points"][0], json({0.0, 0.0}));
        EXPECT_EQ(G["roc"]["1"]["points"][5], json({1.0, 1.0}));
    }
    EXPECT_TRUE(j["naive_vs_expert"]["4"]["observer_means"].contains("U"));
}

}  // namespace
}  // namespace mucosa::study
