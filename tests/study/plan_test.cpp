#include <fstream>
#include <map>
#include <set>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/study/plan.hpp>

#include "test_support.hpp"

namespace mucosa::study {
namespace {

// The paper's design: 5 categories x `patients` x `poses` images.
std::vector<Image> paperImages(int patients = 5, int poses = 8) {
    std::vector<Image> v;
    for (int c = 1; c <= 5; ++c)
        for (int p = 1; p <= patients; ++p)
            for (int q = 1; q <= poses; ++q)
                v.push_back(
                    Image{fmt::format("C{}_P{}_V{}", c, p, q), "/dev/null", c, std::to_string(p), std::to_string(q)});
    return v;
}

TEST(studyPlan, SameSeedSamePlanOtherSeedOtherPlan) {
    PlanOptions o;
    o.observers = 4;
    o.seed = 42;
    const Plan a = makePlan(paperImages(), o), b = makePlan(paperImages(), o);
    EXPECT_EQ(a.fingerprint, b.fingerprint);
    o.seed = 43;
    EXPECT_NE(makePlan(paperImages(), o).fingerprint, a.fingerprint);
}

TEST(studyPlan, PlanIsTheSameOnEveryMachineAndVersion) {
    // The generator and shuffles are our own (not std::'s), so this value may
    // only change with a deliberate change of the planning algorithm, which
    // would orphan the answers databases of studies planned before it.
    PlanOptions o;
    o.observers = 4;
    o.seed = 42;
    // Version 2 of the plan format: the fingerprint covers the options and the files too.
    EXPECT_EQ(makePlan(paperImages(), o).fingerprint, "ba89c840f0d4f9cf");
}

TEST(studyPlan, FollowsTheProtocol) {
    PlanOptions o;
    o.observers = 20;
    o.twoafcPerComparison = 12;
    const Plan plan = makePlan(paperImages(), o);
    int leftHigher = 0, afcTotal = 0;
    for (const ObserverPlan& op : plan.observers) {
        ASSERT_EQ(op.trials.front().kind, TrialKind::Calibration);
        EXPECT_EQ(plan.images[op.trials[0].left].category, 1);
        EXPECT_EQ(plan.images[op.trials[0].right].category, 5);
        std::multiset<int> likert;
        std::map<std::pair<int, int>, int> comparisons;
        bool seenAfc = false;
        for (std::size_t i = 1; i < op.trials.size(); ++i) {
            const Trial& t = op.trials[i];
            ASSERT_NE(t.kind, TrialKind::Calibration);
            if (t.kind == TrialKind::Likert) {
                EXPECT_FALSE(seenAfc) << "Likert after 2AFC";
                likert.insert(t.image);
            } else {
                seenAfc = true;
                const Image &l = plan.images[t.left], &r = plan.images[t.right];
                EXPECT_NE(l.viewKey(), r.viewKey()) << "2AFC pair from the same pose";
                EXPECT_NE(l.category, r.category);
                EXPECT_GE(std::min(l.category, r.category), 3);
                ++comparisons[{std::min(l.category, r.category), std::max(l.category, r.category)}];
                leftHigher += l.category > r.category;
                ++afcTotal;
            }
        }
        // Every image exactly once.
        EXPECT_EQ(likert.size(), plan.images.size());
        EXPECT_EQ(std::set<int>(likert.begin(), likert.end()).size(), plan.images.size());
        EXPECT_EQ(comparisons.size(), 3u);
        for (const auto& [k, n] : comparisons) EXPECT_EQ(n, 12);
    }
    // Left/right is randomised: 720 coin flips, far from all on one side.
    EXPECT_GT(leftHigher, afcTotal * 0.4);
    EXPECT_LT(leftHigher, afcTotal * 0.6);
}

TEST(studyPlan, LikertLimitDrawsEvenlyAcrossCategories) {
    PlanOptions o;
    o.observers = 2;
    o.likertLimit = 15;
    const Plan plan = makePlan(paperImages(), o);
    std::map<int, int> perCategory;
    for (const Trial& t : plan.observers[0].trials)
        if (t.kind == TrialKind::Likert) ++perCategory[plan.images[t.image].category];
    for (int c = 1; c <= 5; ++c) EXPECT_EQ(perCategory[c], 3);
}

TEST(studyPlan, RefusesManifestMissingACategory) {
    auto images = paperImages();
    std::erase_if(images, [](const Image& i) { return i.category == 4; });
    try {
        makePlan(images, {});
        FAIL() << "accepted a manifest without category 4";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("category 4"), std::string::npos) << e.what();
    }
}

TEST(studyPlan, RefusesTwoAfcWhenAllImagesShareOnePose) {
    auto images = paperImages(1, 1);
    EXPECT_THROW(makePlan(images, {}), InputError);
    PlanOptions o;
    o.twoafcPerComparison = 0;  // Likert only: fine
    EXPECT_NO_THROW(makePlan(images, o));
}

// Images in files inside `dir` (a plan must live beside or above its images).
std::vector<Image> imagesIn(const std::filesystem::path& dir) {
    auto images = paperImages(2, 2);
    std::filesystem::create_directories(dir / "img");
    for (Image& im : images) {
        im.file = dir / ("img/" + im.id + ".png");
        std::ofstream(im.file) << "png";
    }
    return images;
}

// The plan written into `dir`, as JSON, for tests that edit it.
nlohmann::json writtenPlan(const std::filesystem::path& dir) {
    PlanOptions o;
    o.observers = 3;
    writePlan(makePlan(imagesIn(dir), o), dir / "study.json");
    return nlohmann::json::parse(test::readBytes(dir / "study.json"));
}

// readPlan's error for `text` saved as the plan, or "" when it is accepted.
std::string planError(const std::filesystem::path& dir, const std::string& text) {
    std::ofstream(dir / "edited.json") << text;
    try {
        readPlan(dir / "edited.json");
        return "";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), (dir / "edited.json").string());
        return e.what();
    }
}

TEST(studyPlan, WritesAndReadsBack) {
    test::TempDir dir;
    PlanOptions o;
    o.observers = 3;
    const Plan plan = makePlan(imagesIn(dir.path()), o);
    const std::string written = writePlan(plan, dir / "study.json");
    const Plan back = readPlan(dir / "study.json");
    EXPECT_EQ(back.fingerprint, written);
    EXPECT_EQ(back.observers.size(), 3u);
    // Files are relative to the plan: a moved study folder still finds its images.
    EXPECT_EQ(back.images[0].file, plan.images[0].file);
    EXPECT_EQ(test::readBytes(dir / "study.json").find("\"file\": \"/"), std::string::npos);
    // A hand-edited plan is refused rather than silently served.
    std::string text = test::readBytes(dir / "study.json");
    text.replace(text.find("\"likert\""), 8, "\"twoafc\"");
    EXPECT_NE(planError(dir.path(), text), "");
}

// Found by the fuzzing campaign (fuzz/corpus/plan/regress-version-2e90.json):
// a version that is a float beyond int's range was converted to int (UB).
TEST(studyPlan, RefusesAVersionThatIsNotTheIntegerItShouldBe) {
    test::TempDir dir;
    const nlohmann::json plan = writtenPlan(dir.path());
    for (const std::string v : {"2e90", "1.5", "-1e300", "\"1\"", "null"}) {
        std::string text = plan.dump();
        const auto at = text.find("\"version\":");
        ASSERT_NE(at, std::string::npos);
        const auto end = text.find_first_of(",}", at);
        text.replace(at, end - at, "\"version\":" + v);
        EXPECT_NE(planError(dir.path(), text).find("unsupported plan version"), std::string::npos) << v;
    }
    nlohmann::json j = plan;
    j.erase("version");
    EXPECT_NE(planError(dir.path(), j.dump()).find("unsupported plan version"), std::string::npos);
}

TEST(studyPlan, RefusesImagesOutsideThePlansFolder) {
    test::TempDir root;
    const std::filesystem::path dir = root / "study", outside = root / "outside";
    std::filesystem::create_directories(outside);
    PlanOptions o;
    o.observers = 1;
    // Writing: an image outside the folder is refused before anything is written.
    auto images = imagesIn(dir);
    images[0].file = outside / "x.png";
    EXPECT_THROW(writePlan(makePlan(images, o), dir / "study.json"), InputError);
    EXPECT_FALSE(std::filesystem::exists(dir / "study.json"));

    std::ofstream(outside / "secret.png") << "secret";
    std::filesystem::create_symlink(outside, dir / "link");
    const nlohmann::json plan = writtenPlan(dir);
    EXPECT_EQ(planError(dir, plan.dump()), "");
    for (const std::string bad : {std::string("/etc/passwd"), std::string("../../../../../../etc/passwd"),
                                  std::string("img/../../outside/secret.png"), std::string("link/secret.png")}) {
        nlohmann::json j = plan;
        j["images"][0]["file"] = bad;
        const std::string error = planError(dir, j.dump());
        EXPECT_NE(error.find("plan's folder"), std::string::npos) << bad << ": " << error;
    }
}

TEST(studyPlan, FingerprintCoversOptionsAndImageFiles) {
    test::TempDir dir;
    const nlohmann::json plan = writtenPlan(dir.path());
    EXPECT_EQ(planError(dir.path(), plan.dump()), "");
    nlohmann::json j = plan;
    j["images"][0]["file"] = plan["images"][1]["file"];  // another image inside the folder
    EXPECT_NE(planError(dir.path(), j.dump()).find("fingerprint"), std::string::npos);
    j = plan;
    j["options"]["series_length"] = plan["options"]["series_length"].get<int>() + 1;
    EXPECT_NE(planError(dir.path(), j.dump()).find("fingerprint"), std::string::npos);
}

TEST(studyPlan, RefusesOptionsOutOfRangeWhenRead) {
    test::TempDir dir;
    const nlohmann::json plan = writtenPlan(dir.path());
    for (const char* bad : {"0", "-1", "4294967297", "3.5", "\"3\"", "1e999"}) {
        nlohmann::json j = plan;
        std::string text = j.dump();
        const std::string key = "\"series_length\":";
        const auto at = text.find(key) + key.size();
        text.replace(at, text.find_first_of(",}", at) - at, bad);
        const std::string error = planError(dir.path(), text);
        EXPECT_NE(error, "") << bad;
        EXPECT_EQ(error.find("fingerprint"), std::string::npos) << bad << " reached the fingerprint: " << error;
    }
}

TEST(studyPlan, OverflowingNumberInAManifestIsATypedError) {
    test::TempDir dir;
    std::ofstream(dir / "m.json") << R"([{"id": "a", "file": "a.png", "category": 1e999, "patient": 1, "pose": 1}])";
    EXPECT_THROW(readManifest(dir / "m.json"), InputError);
}

}  // namespace
}  // namespace mucosa::study
