#pragma once
// `mucosa study analyze`: from ratings (CSV or the answers database) to
// stats.json, an HTML report and the paper's Fig. 6 and Fig. 7.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <mucosa/study/stats.hpp>

namespace mucosa::study {

// The two observer groups of the paper: graduate students and bronchoscopists.
inline constexpr const char* kGroups[] = {"naive", "expert"};

struct Rating {
    std::string observer, group, imageId;
    int category = 0, score = 0;
};

struct Choice {
    std::string observer, group;
    int leftCategory = 0, rightCategory = 0, chosenCategory = 0;
};

struct StudyData {
    std::vector<Rating> ratings;
    std::vector<Choice> choices;
};

// ratings.csv: header with at least observer,group,category,image_id,score
// (other columns ignored). Throws InputError with the line number.
std::vector<Rating> readRatingsCsv(const std::filesystem::path& path);
// pairs.csv: observer,group,left_category,right_category,chosen_category.
std::vector<Choice> readTwoAfcCsv(const std::filesystem::path& path);
// An answers database written by `mucosa study serve`.
StudyData readAnswersDb(const std::filesystem::path& path);
// Reads either, telling them apart by content (SQLite header) not by name.
StudyData readStudyData(const std::filesystem::path& path);

struct CategoryStats {
    int nRatings = 0, nObservers = 0;
    double mean = 0;
    std::optional<double> sd;  // sample SD (n - 1); none for a single rating
};

template <class R>
struct Outcome {  // a result, or why there is none
    std::optional<R> result;
    std::string why;
    std::vector<std::string> excludedObservers;  // observers without the needed categories
};

struct ObserverAuc {                            // one ROC area per observer (GroupAnalysis::observers order)
    std::vector<std::optional<double>> values;  // none: the observer lacks c or 5 ratings
    std::optional<double> mean, sd;             // over the observers with a value; sd is n - 1
};

struct GroupAnalysis {
    std::string group;  // "all", "naive", "expert"
    std::vector<std::string> observers;
    std::map<int, CategoryStats> categories;
    Outcome<FriedmanResult> friedman;
    std::vector<std::vector<double>> observerMeans;        // blocks of friedman, rows = observers kept
    std::map<int, Outcome<WilcoxonResult>> wilcoxon;       // c vs 5
    std::map<int, RocResult> roc;                          // c vs 5, all ratings pooled
    std::map<int, ObserverAuc> observerAuc;                // c vs 5, per observer
    std::map<std::pair<int, int>, BinomialResult> twoafc;  // (lower, higher): k = chose higher
};

struct GroupComparison {                       // naive vs expert within one category
    Outcome<MannWhitneyResult> observerMeans;  // unit = observer (as Friedman and Wilcoxon)
    Outcome<MannWhitneyResult> ratings;        // unit = single rating
};

struct Analysis {
    std::vector<int> categories;        // present in the data, ascending
    std::vector<GroupAnalysis> groups;  // "all" first
    std::map<int, GroupComparison> naiveVsExpert;
    std::vector<std::string> warnings;  // documented handling that changed what was computed
};

// Throws InputError when the data cannot support the analysis (no ratings, no
// category 5 reference, an observer in two groups).
Analysis analyze(const StudyData& data);

// REPORT_DIR/stats.json, report.html, fig6_scores.svg, fig7_roc.svg, each
// written atomically; the folder is created if needed.
void writeReport(const Analysis& analysis, const std::filesystem::path& dir, const std::string& source);
std::string statsJson(const Analysis& analysis, const std::string& source);

// The data in the CSV formats of docs/cli.md ("mucosa study") (ratings.csv, and pairs.csv when there
// are 2AFC answers), e.g. to take an answers database to R or SciPy.
void writeCsv(const StudyData& data, const std::filesystem::path& dir);

}  // namespace mucosa::study
