// The paper's analysis (section "Results"): per-category mean and SD per group
// (Fig. 6), Friedman across categories, Wilcoxon signed-rank of each category
// against the real frames, 2AFC proportions, ROC curves from Likert scores
// (Fig. 7), and naive against expert.
#include <mucosa/study/analysis.hpp>

#include <algorithm>
#include <cmath>
#include <set>
#include <unordered_map>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/study/plan.hpp>

namespace mucosa::study {

namespace {

struct Sum {
    long long total = 0;
    int count = 0;
    // Integer sum then one division: equal means are bit-identical, so ties
    // between observer means are seen as ties (as numpy's mean sees them).
    double mean() const { return static_cast<double>(total) / count; }
};

struct ObserverCells {
    std::string id;
    std::map<int, Sum> byCategory;
    std::map<int, std::vector<int>> scores;  // for the per-observer ROC
};

GroupAnalysis analyzeGroup(const std::string& group, const StudyData& data, const std::vector<int>& categories,
                           std::vector<std::string>& warnings) {
    GroupAnalysis g;
    g.group = group;
    auto inGroup = [&](const std::string& gr) { return group == "all" || gr == group; };

    std::vector<ObserverCells> obs;
    std::unordered_map<std::string, std::size_t> index;
    std::map<int, std::vector<int>> scores;
    for (const Rating& r : data.ratings) {
        if (!inGroup(r.group)) continue;
        auto [it, added] = index.emplace(r.observer, obs.size());
        if (added) obs.push_back(ObserverCells{r.observer, {}, {}});
        obs[it->second].scores[r.category].push_back(r.score);
        Sum& s = obs[it->second].byCategory[r.category];
        s.total += r.score;
        ++s.count;
        scores[r.category].push_back(r.score);
    }
    for (const auto& o : obs) g.observers.push_back(o.id);

    for (int c : categories) {
        CategoryStats cs;
        const auto& v = scores[c];
        cs.nRatings = static_cast<int>(v.size());
        for (const auto& o : obs) cs.nObservers += o.byCategory.count(c) ? 1 : 0;
        if (!v.empty()) {
            long long total = 0;
            for (int s : v) total += s;
            cs.mean = static_cast<double>(total) / static_cast<double>(v.size());
            if (v.size() > 1) {
                double ss = 0;
                for (int s : v) ss += (s - cs.mean) * (s - cs.mean);
                cs.sd = std::sqrt(ss / static_cast<double>(v.size() - 1));
            }
        }
        if (cs.nRatings > 0) g.categories[c] = cs;
    }

    // Friedman: blocks = observers, treatments = categories, value = the
    // observer's mean score in the category. Only complete blocks can be ranked.
    for (const auto& o : obs) {
        std::vector<double> row;
        for (int c : categories)
            if (auto it = o.byCategory.find(c); it != o.byCategory.end()) row.push_back(it->second.mean());
        if (row.size() == categories.size()) {
            g.observerMeans.push_back(std::move(row));
        } else {
            g.friedman.excludedObservers.push_back(o.id);
        }
    }
    g.friedman.result = friedman(g.observerMeans, &g.friedman.why);
    if (!g.friedman.excludedObservers.empty())
        warnings.push_back(fmt::format("group {}: Friedman test leaves out {} {} who did not rate every category: {}",
                                       group, g.friedman.excludedObservers.size(),
                                       g.friedman.excludedObservers.size() == 1 ? "observer" : "observers",
                                       fmt::join(g.friedman.excludedObservers, ", ")));

    // Wilcoxon signed-rank, each category against the real frames, paired by observer means.
    for (int c : categories) {
        if (c == kReferenceCategory) continue;
        Outcome<WilcoxonResult> w;
        std::vector<double> x, y;
        for (const auto& o : obs) {
            auto a = o.byCategory.find(c), b = o.byCategory.find(kReferenceCategory);
            if (a != o.byCategory.end() && b != o.byCategory.end()) {
                x.push_back(a->second.mean());
                y.push_back(b->second.mean());
            } else {
                w.excludedObservers.push_back(o.id);
            }
        }
        w.result = wilcoxonSignedRank(x, y, &w.why);
        if (!w.excludedObservers.empty())
            warnings.push_back(fmt::format("group {}: Wilcoxon {} vs {} leaves out {} {} without ratings in both: {}",
                                           group, c, kReferenceCategory, w.excludedObservers.size(),
                                           w.excludedObservers.size() == 1 ? "observer" : "observers",
                                           fmt::join(w.excludedObservers, ", ")));
        g.wilcoxon[c] = std::move(w);
        if (!scores[c].empty() && !scores[kReferenceCategory].empty())
            g.roc[c] = roc(scores[c], scores[kReferenceCategory]);
        // Each observer's own ROC area (Hanley & McNeil 1982 style reader
        // analysis): how well that observer alone tells c from real frames.
        ObserverAuc oa;
        std::vector<double> defined;
        for (const auto& o : obs) {
            auto a = o.scores.find(c), b = o.scores.find(kReferenceCategory);
            if (a == o.scores.end() || b == o.scores.end()) {
                oa.values.emplace_back(std::nullopt);
                continue;
            }
            oa.values.emplace_back(roc(a->second, b->second).auc);
            defined.push_back(*oa.values.back());
        }
        if (!defined.empty()) {
            double sum = 0;
            for (double v : defined) sum += v;
            oa.mean = sum / static_cast<double>(defined.size());
            if (defined.size() > 1) {
                double ss = 0;
                for (double v : defined) ss += (v - *oa.mean) * (v - *oa.mean);
                oa.sd = std::sqrt(ss / static_cast<double>(defined.size() - 1));
            }
        }
        g.observerAuc[c] = std::move(oa);
    }

    // 2AFC: for each unordered pair of categories, how often the higher one won.
    std::map<std::pair<int, int>, std::pair<int, int>> counts;  // (k higher chosen, n)
    for (const Choice& ch : data.choices) {
        if (!inGroup(ch.group)) continue;
        const int lo = std::min(ch.leftCategory, ch.rightCategory), hi = std::max(ch.leftCategory, ch.rightCategory);
        auto& [k, n] = counts[{lo, hi}];
        k += ch.chosenCategory == hi ? 1 : 0;
        ++n;
    }
    for (const auto& [key, kn] : counts) g.twoafc[key] = binomialTest(kn.first, kn.second);
    return g;
}

}  // namespace

Analysis analyze(const StudyData& data) {
    if (data.ratings.empty()) throw InputError("ratings", "", "there are no ratings to analyse");
    Analysis a;
    std::map<std::string, std::string> groupOf;
    auto checkGroup = [&](const std::string& observer, const std::string& group) {
        auto [it, added] = groupOf.emplace(observer, group);
        if (!added && it->second != group)
            throw InputError(
                "group", "",
                fmt::format("observer '{}' appears in both groups {} and {}", observer, it->second, group));
    };
    std::set<int> cats;
    for (const Rating& r : data.ratings) {
        if (r.category < kMinCategory || r.category > kMaxCategory)
            throw InputError("category", "", fmt::format("category {} is outside 1-5", r.category));
        if (r.score < 1 || r.score > 5) throw InputError("score", "", fmt::format("score {} is outside 1-5", r.score));
        checkGroup(r.observer, r.group);
        cats.insert(r.category);
    }
    for (const Choice& c : data.choices) checkGroup(c.observer, c.group);
    if (!cats.count(kReferenceCategory))
        throw InputError("ratings", "",
                         "no ratings of category 5: the real frames are the reference of the Wilcoxon tests and ROC "
                         "curves");
    a.categories.assign(cats.begin(), cats.end());
    for (int c = kMinCategory; c <= kMaxCategory; ++c)
        if (!cats.count(c))
            a.warnings.push_back(fmt::format("no ratings of category {}: it is left out of every statistic", c));

    std::set<std::string> present;
    for (const auto& [o, g] : groupOf) present.insert(g);
    a.groups.push_back(analyzeGroup("all", data, a.categories, a.warnings));
    for (const char* g : kGroups)
        if (present.count(g)) a.groups.push_back(analyzeGroup(g, data, a.categories, a.warnings));

    // Naive vs expert per category (Mann-Whitney): on observer means (the
    // observer is the unit, as in the Friedman and Wilcoxon tests) and on
    // single ratings (treats ratings as independent; reported for comparison).
    if (present.count("naive") && present.count("expert")) {
        for (int c : a.categories) {
            std::map<std::string, std::map<std::string, Sum>> means;  // group -> observer -> sum
            std::map<std::string, std::vector<double>> raw;
            for (const Rating& r : data.ratings) {
                if (r.category != c) continue;
                Sum& s = means[r.group][r.observer];
                s.total += r.score;
                ++s.count;
                raw[r.group].push_back(r.score);
            }
            auto meanList = [&](const std::string& g) {
                std::vector<double> v;
                // Observer order of first appearance is not needed: U does not depend on order.
                for (const auto& [o, s] : means[g]) v.push_back(s.mean());
                return v;
            };
            GroupComparison gc;
            gc.observerMeans.result = mannWhitney(meanList("naive"), meanList("expert"), &gc.observerMeans.why);
            gc.ratings.result = mannWhitney(raw["naive"], raw["expert"], &gc.ratings.why);
            a.naiveVsExpert[c] = std::move(gc);
        }
    } else {
        a.warnings.push_back("only one group in the data: no naive vs expert comparison");
    }
    return a;
}

}  // namespace mucosa::study
