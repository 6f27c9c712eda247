// `mucosa study plan|serve|analyze` from the outside: outputs, and bad input giving
// one `error:` line, a non-zero exit and no output file.
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.hpp"

namespace mucosa::test {
namespace {

using nlohmann::json;

void write(const std::filesystem::path& p, const std::string& text) {
    std::ofstream(p) << text;
}

int lines(const std::string& s) {
    return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
}

void expectOneLineError(const RunResult& r, const std::string& needle) {
    EXPECT_NE(r.exitCode, 0);
    EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << r.err;
    EXPECT_EQ(lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
}

std::string manifest(const TempDir& dir, int poses) {
    json images = json::array();
    for (int c = 1; c <= 5; ++c)
        for (int q = 1; q <= poses; ++q) {
            const std::string name = fmt::format("c{}_v{}.png", c, q);
            write(dir / name, "not really a png");
            images.push_back({{"id", name}, {"file", name}, {"category", c}, {"patient", 1}, {"pose", q}});
        }
    write(dir / "images.json", json{{"images", images}}.dump());
    return (dir / "images.json").string();
}

TEST(studyCli, EverySubcommandHasHelp) {
    for (const char* sub : {"", " plan", " serve", " analyze"}) {
        const auto r = runCli(std::string("study") + sub + " --help");
        EXPECT_EQ(r.exitCode, 0) << sub;
        EXPECT_NE(r.out.find("Usage"), std::string::npos) << sub;
    }
}

TEST(studyCli, ServeHelpNamesTheLinksAndLimits) {
    const auto r = runCli("study serve --help");
    for (const char* opt : {"--links-out", "--client-connections", "--max-connections", "?t=TOKEN"})
        EXPECT_NE(r.out.find(opt), std::string::npos) << opt;
}

TEST(studyCli, ServeRefusesAnUnwritableLinksFileBeforeServing) {
    TempDir dir;
    expectOneLineError(
        runCli("study serve '" + (dir / "study.json").string() + "' --db '" + (dir / "a.sqlite").string() +
               "' --port 0 --links-out '" + (dir / "missing" / "links.txt").string() + "'"),
        "links.txt");
    EXPECT_FALSE(std::filesystem::exists(dir / "a.sqlite"));
}

TEST(studyCli, PlanWritesAReproduciblePlan) {
    TempDir dir;
    const std::string m = manifest(dir, 3);
    const auto r1 =
        runCli("study plan --manifest '" + m + "' -o '" + (dir / "a.json").string() + "' --observers 5 --seed 9");
    ASSERT_EQ(r1.exitCode, 0) << r1.err;
    const auto r2 =
        runCli("study plan --manifest '" + m + "' -o '" + (dir / "b.json").string() + "' --observers 5 --seed 9");
    ASSERT_EQ(r2.exitCode, 0) << r2.err;
    EXPECT_EQ(readBytes(dir / "a.json"), readBytes(dir / "b.json"));
    const json plan = json::parse(readBytes(dir / "a.json"));
    EXPECT_EQ(plan["observers"].size(), 5u);
}

TEST(studyCli, PlanRefusesAnUnsatisfiableManifest) {
    TempDir dir;
    write(dir / "x.png", "x");
    write(dir / "images.json", R"({"images":[{"id":"a","file":"x.png","category":1,"patient":1,"pose":1},
                                            {"id":"b","file":"x.png","category":5,"patient":1,"pose":1}]})");
    const auto r =
        runCli("study plan --manifest '" + (dir / "images.json").string() + "' -o '" + (dir / "p.json").string() + "'");
    expectOneLineError(r, "category 2 has no images");
    EXPECT_FALSE(std::filesystem::exists(dir / "p.json"));
}

TEST(studyCli, PlanRefusesAMissingImageFile) {
    TempDir dir;
    write(dir / "images.json", R"([{"id":"a","file":"nope.png","category":1,"patient":1,"pose":1}])");
    expectOneLineError(
        runCli("study plan --manifest '" + (dir / "images.json").string() + "' -o '" + (dir / "p.json").string() + "'"),
        "does not exist");
}

TEST(studyCli, AnalyzeWritesTheReport) {
    TempDir dir;
    const auto r = runCli("study analyze '" + testdata("study/ratings_A_main.csv").string() + "' -o '" +
                          (dir / "report").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const char* f : {"stats.json", "report.html", "fig6_scores.svg", "fig7_roc.svg", "ratings.csv"})
        EXPECT_TRUE(std::filesystem::exists(dir / "report" / f)) << f;
    const json s = json::parse(readBytes(dir / "report" / "stats.json"));
    EXPECT_NEAR(s["all"]["friedman"]["chi2"].get<double>(), 88.14814814814815, 1e-9);
}

// One spelling in the help (analyze); the British one still runs, unlisted.
TEST(studyCli, AnalyseIsAHiddenAliasOfAnalyze) {
    const auto help = runCli("study --help");
    ASSERT_EQ(help.exitCode, 0) << help.err;
    EXPECT_NE(help.out.find("analyze"), std::string::npos) << help.out;
    EXPECT_EQ(help.out.find("analyse"), std::string::npos) << help.out;
    TempDir dir;
    const auto r = runCli("study analyse '" + testdata("study/ratings_A_main.csv").string() + "' -o '" +
                          (dir / "report").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "report" / "stats.json"));
}

struct BadCase {
    const char* name;
    const char* csv;
    const char* needle;
};

TEST(studyCli, AnalyzeRejectsBadRatingsWithOneLine) {
    const BadCase cases[] = {
        {"score out of range", "observer,group,category,image_id,score\nA,naive,1,x,7\n", "line 2: 7 is outside 1-5"},
        {"score not a number", "observer,group,category,image_id,score\nA,naive,1,x,3.5\n", "not a whole number"},
        {"unknown group", "observer,group,category,image_id,score\nA,student,1,x,3\n", "unknown group 'student'"},
        {"missing column", "observer,group,category,score\nA,naive,1,3\n", "missing column(s) image_id"},
        {"category 6", "observer,group,category,image_id,score\nA,naive,6,x,3\n", "6 is outside 1-5"},
        {"no reference", "observer,group,category,image_id,score\nA,naive,1,x,3\nA,naive,2,y,3\n",
         "no ratings of category 5"},
        {"two groups", "observer,group,category,image_id,score\nA,naive,1,x,3\nA,expert,5,y,3\n",
         "appears in both groups"},
        {"empty", "", "empty"},
        {"short row", "observer,group,category,image_id,score\nA,naive,1\n", "line 2: 3 fields"},
    };
    for (const BadCase& c : cases) {
        SCOPED_TRACE(c.name);
        TempDir dir;
        write(dir / "r.csv", c.csv);
        const auto r = runCli("study analyze '" + (dir / "r.csv").string() + "' -o '" + (dir / "out").string() + "'");
        expectOneLineError(r, c.needle);
        EXPECT_FALSE(std::filesystem::exists(dir / "out" / "stats.json"));
    }
    TempDir dir;
    expectOneLineError(
        runCli("study analyze '" + (dir / "missing.csv").string() + "' -o '" + (dir / "o").string() + "'"),
        "missing.csv");
}

TEST(studyCli, AnalyzeRejectsBadTwoAfcRows) {
    TempDir dir;
    const std::string ratings = testdata("study/ratings_A_main.csv").string();
    write(dir / "p.csv", "observer,group,left_category,right_category,chosen_category\nN01,naive,3,4,5\n");
    expectOneLineError(runCli("study analyze '" + ratings + "' --twoafc '" + (dir / "p.csv").string() + "' -o '" +
                              (dir / "o").string() + "'"),
                       "neither the left");
    write(dir / "q.csv", "observer,group,left_category,right_category,chosen_category\nN01,expert,3,4,4\n");
    expectOneLineError(runCli("study analyze '" + ratings + "' --twoafc '" + (dir / "q.csv").string() + "' -o '" +
                              (dir / "o").string() + "'"),
                       "appears in both groups");
}

TEST(studyCli, ObserverWithoutACategoryIsExcludedAndSaidSo) {
    TempDir dir;
    std::string csv = "observer,group,category,image_id,score\n";
    const int scores[4][5] = {{1, 2, 3, 4, 5}, {2, 2, 3, 5, 4}, {1, 3, 3, 4, 5}, {2, 1, 4, 4, 5}};
    for (int o = 0; o < 4; ++o)
        for (int c = 1; c <= 5; ++c) csv += fmt::format("O{},naive,{},i,{}\n", o, c, scores[o][c - 1]);
    csv += "LATE,naive,1,i,2\nLATE,naive,5,i,4\n";  // never rated 2, 3, 4
    write(dir / "r.csv", csv);
    const auto r = runCli("study analyze '" + (dir / "r.csv").string() + "' -o '" + (dir / "out").string() + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("warning: group all: Friedman test leaves out 1 observer who"), std::string::npos) << r.err;
    const json s = json::parse(readBytes(dir / "out" / "stats.json"));
    EXPECT_EQ(s["all"]["friedman"]["n_blocks"], 4);
    EXPECT_EQ(s["all"]["friedman"]["excluded_observers"], json({"LATE"}));
    EXPECT_EQ(s["all"]["wilcoxon"]["1"]["n_pairs"], 5);  // LATE has 1 and 5
    EXPECT_EQ(s["all"]["wilcoxon"]["2"]["n_pairs"], 4);
    EXPECT_FALSE(s.contains("naive_vs_expert"));
}

}  // namespace
}  // namespace mucosa::test
