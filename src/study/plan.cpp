#include <mucosa/study/plan.hpp>

#include <algorithm>
#include <limits>
#include <map>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

#include "core/json_parse.hpp"
#include "rng.hpp"

namespace mucosa::study {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kPlanFormat = "mucosa-study-plan";
// Version 2: the fingerprint also covers the options and the image files.
constexpr int kPlanVersion = 2;
// The paper's 2AFC compares categories 3, 4 and 5 pairwise.
constexpr std::pair<int, int> kComparisons[] = {{3, 4}, {3, 5}, {4, 5}};

// The shared parse (a syntax error at its line and column), as a "<what>" file:
// "not valid JSON: ..." either way.
json parseJson(const std::string& text, const std::string& file, const std::string& what) {
    try {
        return mucosa::detail::parseJsonFile(text, file);
    } catch (const InputError& e) {
        if (e.line() > 0) throw InputError(what, file, e.line(), e.column(), "not valid JSON: " + e.reason());
        throw InputError(what, file, "not valid JSON: " + e.reason());
    }
}

std::string scalarText(const json& v) {
    if (v.is_string()) return v.get<std::string>();
    if (v.is_number_integer()) return std::to_string(v.get<long long>());
    return {};
}

bool validId(const std::string& s) {
    return !s.empty() && s.size() <= 200 &&
           std::none_of(s.begin(), s.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; });
}

std::uint64_t fnv1a(const std::string& s) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : s) {
        h ^= c;
        h *= 0x100000001b3ull;
    }
    return h;
}

json trialJson(const Trial& t) {
    json j{{"kind", trialKindName(t.kind)}};
    if (t.kind == TrialKind::Likert) {
        j["image"] = t.image;
    } else {
        j["left"] = t.left;
        j["right"] = t.right;
    }
    return j;
}

// `base` empty: no file names (what the fingerprint covers, so a study folder
// can move without orphaning its database); otherwise files relative to it.
json imagesJson(const std::vector<Image>& images, const fs::path& base = {}) {
    json a = json::array();
    for (const Image& im : images) {
        json j{{"id", im.id}, {"category", im.category}, {"patient", im.patient}, {"pose", im.pose}};
        if (!base.empty()) j["file"] = im.file.lexically_relative(base).generic_string();
        a.push_back(std::move(j));
    }
    return a;
}

json observersJson(const std::vector<ObserverPlan>& observers) {
    json a = json::array();
    for (const ObserverPlan& o : observers) {
        json t = json::array();
        for (const Trial& tr : o.trials) t.push_back(trialJson(tr));
        a.push_back({{"trials", std::move(t)}});
    }
    return a;
}

json optionsJson(const PlanOptions& o) {
    return {{"observers", o.observers},
            {"seed", o.seed},
            {"series_length", o.seriesLength},
            {"likert_limit", o.likertLimit},
            {"twoafc_per_comparison", o.twoafcPerComparison}};
}

// Covers everything the server acts on: options, images (with their files
// relative to the plan, so the folder can still move) and every trial.
std::string fingerprintOf(const json& options, const json& images, const json& observers) {
    return fmt::format("{:016x}", fnv1a(options.dump() + "\n" + images.dump() + "\n" + observers.dump()));
}

// Whether `rel` (relative to `folder`) names a file inside `folder` once `..`
// and symlinks are resolved.
bool insideFolder(const fs::path& rel, const fs::path& folder) {
    if (rel.empty() || rel.is_absolute()) return false;
    std::error_code ec;
    const fs::path realFolder = fs::weakly_canonical(folder, ec);
    if (ec) return false;
    const fs::path real = fs::weakly_canonical(folder / rel, ec);
    if (ec) return false;
    const fs::path inside = real.lexically_relative(realFolder);
    return !inside.empty() && *inside.begin() != ".." && *inside.begin() != ".";
}

// One rule for plans made and plans read: a plan file holding options outside
// these ranges (series length 0 divides by zero in the server) is refused.
void checkOptions(const PlanOptions& o, const std::string& file) {
    if (o.observers < 1 || o.observers > 100000) throw InputError("observers", file, "must be 1..100000");
    if (o.seriesLength < 1) throw InputError("series length", file, "must be at least 1");
    if (o.likertLimit < 0) throw InputError("Likert limit", file, "must be 0 (every image) or more");
    if (o.twoafcPerComparison < 0 || o.twoafcPerComparison > 10000)
        throw InputError("2AFC pairs", file, "must be 0..10000 per comparison");
}

// Reads an int option exactly: 1e999, 3.5, "3" or 4294967299 are refused, never truncated.
int intOption(const json& o, const char* key, const std::string& file) {
    const json& v = o.at(key);
    if (!v.is_number_integer() || v.get<long long>() < std::numeric_limits<int>::min() ||
        v.get<long long>() > std::numeric_limits<int>::max())
        throw InputError("plan", file, fmt::format("option \"{}\" must be an integer (got {})", key, v.dump()));
    return static_cast<int>(v.get<long long>());
}

}  // namespace

const char* trialKindName(TrialKind kind) {
    switch (kind) {
        case TrialKind::Calibration:
            return "calibration";
        case TrialKind::Likert:
            return "likert";
        case TrialKind::TwoAfc:
            return "twoafc";
    }
    return "?";
}

int ObserverPlan::likertCount() const {
    return static_cast<int>(
        std::count_if(trials.begin(), trials.end(), [](const Trial& t) { return t.kind == TrialKind::Likert; }));
}

std::vector<Image> readManifest(const fs::path& path) {
    const std::string file = path.string();
    const json j = parseJson(readTextFile(path), file, "manifest");
    const json* list = &j;
    if (j.is_object()) {
        if (!j.contains("images")) throw InputError("manifest", file, "has no \"images\" list");
        list = &j["images"];
    }
    if (!list->is_array()) throw InputError("manifest", file, "\"images\" must be a list");
    const fs::path base = fs::absolute(path).parent_path();
    std::vector<Image> images;
    std::set<std::string> ids;
    for (std::size_t i = 0; i < list->size(); ++i) {
        const json& e = (*list)[i];
        const std::string where = fmt::format("image #{}", i + 1);
        if (!e.is_object()) throw InputError("manifest", file, where + " is not an object");
        Image im;
        for (const char* key : {"id", "file", "category", "patient", "pose"})
            if (!e.contains(key)) throw InputError("manifest", file, fmt::format("{} has no \"{}\"", where, key));
        im.id = scalarText(e["id"]);
        if (!validId(im.id)) throw InputError("manifest", file, where + ": \"id\" must be a non-empty string");
        if (!ids.insert(im.id).second)
            throw InputError("manifest", file, fmt::format("{}: id '{}' appears twice", where, im.id));
        if (!e["file"].is_string() || e["file"].get<std::string>().empty())
            throw InputError("manifest", file, fmt::format("image '{}': \"file\" must be a path", im.id));
        im.file = fs::path(e["file"].get<std::string>());
        if (im.file.is_relative()) im.file = base / im.file;
        im.file = im.file.lexically_normal();
        if (!e["category"].is_number_integer() || e["category"].get<long long>() < kMinCategory ||
            e["category"].get<long long>() > kMaxCategory)
            throw InputError(
                "manifest", file,
                fmt::format("image '{}': \"category\" must be an integer 1-5 (got {})", im.id, e["category"].dump()));
        im.category = e["category"].get<int>();
        im.patient = scalarText(e["patient"]);
        im.pose = scalarText(e["pose"]);
        if (im.patient.empty() || im.pose.empty())
            throw InputError("manifest", file,
                             fmt::format("image '{}': \"patient\" and \"pose\" must be strings or integers", im.id));
        std::error_code ec;
        if (!fs::is_regular_file(im.file, ec))
            throw InputError("manifest", file,
                             fmt::format("image '{}': file {} does not exist", im.id, im.file.string()));
        images.push_back(std::move(im));
    }
    return images;
}

Plan makePlan(std::vector<Image> images, const PlanOptions& o) {
    checkOptions(o, "");
    if (images.empty()) throw InputError("manifest", "", "lists no images");

    std::map<int, std::vector<int>> byCategory;
    for (std::size_t i = 0; i < images.size(); ++i) byCategory[images[i].category].push_back(static_cast<int>(i));
    for (int c = kMinCategory; c <= kMaxCategory; ++c)
        if (byCategory[c].empty())
            throw InputError("manifest", "",
                             fmt::format("category {} has no images (the protocol rates categories 1-5 and "
                                         "calibrates with a category 1 beside a category 5 image)",
                                         c));
    if (o.twoafcPerComparison > 0) {
        for (auto [a, b] : kComparisons) {
            std::set<std::string> poses;
            for (int i : byCategory[a]) poses.insert(images[static_cast<std::size_t>(i)].viewKey());
            for (int i : byCategory[b]) poses.insert(images[static_cast<std::size_t>(i)].viewKey());
            if (poses.size() < 2)
                throw InputError("manifest", "",
                                 fmt::format("2AFC needs a category {} and a category {} image from different poses, "
                                             "but all of them show one pose (use --twoafc 0 to skip 2AFC)",
                                             a, b));
        }
    }

    Plan plan;
    plan.images = std::move(images);
    plan.options = o;
    detail::SplitMix64 root(o.seed);
    for (int s = 0; s < o.observers; ++s) {
        // Each observer's stream depends only on (seed, slot), so adding slots
        // later leaves the earlier ones unchanged.
        detail::SplitMix64 rng(root.next() ^ (0xD1B54A32D192ED03ull * static_cast<std::uint64_t>(s + 1)));
        ObserverPlan op;
        // Calibration: a category-1 image beside a category-5 one, of the same
        // pose when there is one (the difference is then only realism).
        Trial cal{TrialKind::Calibration};
        const auto& c1 = byCategory[kMinCategory];
        const auto& c5 = byCategory[kReferenceCategory];
        cal.left = c1[rng.below(c1.size())];
        std::vector<int> samePose;
        for (int i : c5)
            if (plan.images[static_cast<std::size_t>(i)].viewKey() ==
                plan.images[static_cast<std::size_t>(cal.left)].viewKey())
                samePose.push_back(i);
        cal.right = samePose.empty() ? c5[rng.below(c5.size())] : samePose[rng.below(samePose.size())];
        op.trials.push_back(cal);

        // Likert: every image (or a limit, drawn evenly across categories), in random order.
        std::vector<int> likert;
        if (o.likertLimit == 0 || o.likertLimit >= static_cast<int>(plan.images.size())) {
            for (std::size_t i = 0; i < plan.images.size(); ++i) likert.push_back(static_cast<int>(i));
        } else {
            std::vector<std::vector<int>> pools;
            for (auto& [c, list] : byCategory) {
                pools.push_back(list);
                rng.shuffle(pools.back());
            }
            for (std::size_t round = 0; static_cast<int>(likert.size()) < o.likertLimit; ++round)
                for (auto& pool : pools)
                    if (round < pool.size() && static_cast<int>(likert.size()) < o.likertLimit)
                        likert.push_back(pool[round]);
        }
        rng.shuffle(likert);
        for (int i : likert) op.trials.push_back(Trial{TrialKind::Likert, i});

        // 2AFC: per comparison, images of the lower category cycle in a shuffled
        // order; the partner is drawn from the other category's other poses.
        std::vector<Trial> afc;
        for (auto [a, b] : kComparisons) {
            std::vector<int> as = byCategory[a];
            rng.shuffle(as);
            std::size_t next = 0;
            for (int m = 0; m < o.twoafcPerComparison; ++m) {
                for (std::size_t tries = 0; tries < as.size(); ++tries) {
                    const int ia = as[next++ % as.size()];
                    std::vector<int> partners;
                    for (int ib : byCategory[b])
                        if (plan.images[static_cast<std::size_t>(ib)].viewKey() !=
                            plan.images[static_cast<std::size_t>(ia)].viewKey())
                            partners.push_back(ib);
                    if (partners.empty()) continue;
                    const int ib = partners[rng.below(partners.size())];
                    Trial t{TrialKind::TwoAfc};
                    const bool swap = rng.coin();
                    t.left = swap ? ib : ia;
                    t.right = swap ? ia : ib;
                    afc.push_back(t);
                    break;
                }
            }
        }
        rng.shuffle(afc);
        op.trials.insert(op.trials.end(), afc.begin(), afc.end());
        plan.observers.push_back(std::move(op));
    }
    // Without a plan file the files are absolute; writePlan and readPlan
    // fingerprint them relative to the plan.
    plan.fingerprint =
        fingerprintOf(optionsJson(o), imagesJson(plan.images, fs::path("/")), observersJson(plan.observers));
    return plan;
}

std::string writePlan(const Plan& plan, const fs::path& path) {
    // Files are stored relative to the plan, so the study folder (plan,
    // images, database) can be moved or copied to another machine as a whole.
    const fs::path base = fs::absolute(path).parent_path().lexically_normal();
    const json observers = observersJson(plan.observers);
    for (const Image& im : plan.images) {
        // The same rule as readPlan's, symlinks resolved, so what is written can be read.
        if (!insideFolder(im.file.lexically_relative(base), base))
            throw InputError("plan", path.string(),
                             fmt::format("image '{}' ({}) is outside the plan's folder; put the plan beside or above "
                                         "its images, so the study folder holds everything it serves",
                                         im.id, im.file.string()));
    }
    const json images = imagesJson(plan.images, base);
    const std::string fingerprint = fingerprintOf(optionsJson(plan.options), images, observers);
    json j{{"format", kPlanFormat},      {"version", kPlanVersion},
           {"fingerprint", fingerprint}, {"options", optionsJson(plan.options)},
           {"images", images},           {"observers", observers}};
    writeFileAtomic(path, j.dump(1) + "\n");
    return fingerprint;
}

Plan readPlan(const fs::path& path) {
    const std::string file = path.string();
    const json j = parseJson(readTextFile(path), file, "plan");
    try {
        if (!j.is_object() || j.value("format", "") != kPlanFormat)
            throw InputError("plan", file, "not a study plan (make one with `mucosa study plan`)");
        // An integer first: get<int> of a float out of int's range is undefined.
        if (!j.contains("version") || !j["version"].is_number_integer() ||
            j["version"].get<std::int64_t>() != kPlanVersion)
            throw InputError(
                "plan", file,
                fmt::format("unsupported plan version {}", j.contains("version") ? j["version"].dump() : "(none)"));
        Plan plan;
        const json& o = j.at("options");
        if (!o.at("seed").is_number_unsigned())
            throw InputError("plan", file, "option \"seed\" must be an unsigned integer");
        plan.options.observers = intOption(o, "observers", file);
        plan.options.seed = o.at("seed").get<std::uint64_t>();
        plan.options.seriesLength = intOption(o, "series_length", file);
        plan.options.likertLimit = intOption(o, "likert_limit", file);
        plan.options.twoafcPerComparison = intOption(o, "twoafc_per_comparison", file);
        checkOptions(plan.options, file);
        const fs::path base = fs::absolute(path).parent_path().lexically_normal();
        for (const json& e : j.at("images")) {
            Image im;
            im.id = e.at("id").get<std::string>();
            const fs::path given(e.at("file").get<std::string>());
            // Images stay inside the plan's folder: no absolute paths, no `..`
            // escapes, no symlinks leading out of it.
            if (given.empty() || given.is_absolute() || given.has_root_name())
                throw InputError("plan", file,
                                 fmt::format("image '{}': file must be a path inside the plan's folder", im.id));
            im.file = (base / given).lexically_normal();
            if (!insideFolder(given, base))
                throw InputError(
                    "plan", file,
                    fmt::format("image '{}': file {} is outside the plan's folder", im.id, given.string()));
            if (!e.at("category").is_number_integer())
                throw InputError("plan", file, fmt::format("image '{}': category must be an integer", im.id));
            const long long category = e.at("category").get<long long>();
            if (category < kMinCategory || category > kMaxCategory)
                throw InputError("plan", file, fmt::format("image '{}' has category {}", im.id, category));
            im.category = static_cast<int>(category);
            im.patient = e.at("patient").get<std::string>();
            im.pose = e.at("pose").get<std::string>();
            if (im.category < kMinCategory || im.category > kMaxCategory)
                throw InputError("plan", file, fmt::format("image '{}' has category {}", im.id, im.category));
            plan.images.push_back(std::move(im));
        }
        const int nImages = static_cast<int>(plan.images.size());
        auto index = [&](const json& v) {
            if (!v.is_number_integer() || v.get<long long>() < 0 || v.get<long long>() >= nImages)
                throw InputError("plan", file, fmt::format("image index {} out of range", v.dump()));
            const int i = static_cast<int>(v.get<long long>());
            if (i < 0 || i >= nImages) throw InputError("plan", file, fmt::format("image index {} out of range", i));
            return i;
        };
        for (const json& ob : j.at("observers")) {
            ObserverPlan op;
            for (const json& t : ob.at("trials")) {
                Trial tr;
                const std::string kind = t.at("kind").get<std::string>();
                if (kind == "likert") {
                    tr.kind = TrialKind::Likert;
                    tr.image = index(t.at("image"));
                } else if (kind == "calibration" || kind == "twoafc") {
                    tr.kind = kind == "twoafc" ? TrialKind::TwoAfc : TrialKind::Calibration;
                    tr.left = index(t.at("left"));
                    tr.right = index(t.at("right"));
                } else {
                    throw InputError("plan", file, "unknown trial kind '" + kind + "'");
                }
                op.trials.push_back(tr);
            }
            if (op.trials.empty() || op.trials.front().kind != TrialKind::Calibration)
                throw InputError("plan", file, "an observer's trials must start with the calibration pair");
            plan.observers.push_back(std::move(op));
        }
        if (plan.observers.empty()) throw InputError("plan", file, "plans no observers");
        plan.fingerprint =
            fingerprintOf(optionsJson(plan.options), imagesJson(plan.images, base), observersJson(plan.observers));
        if (j.value("fingerprint", "") != plan.fingerprint)
            throw InputError("plan", file, "fingerprint does not match its content (the file was edited by hand?)");
        return plan;
    } catch (const json::exception& e) {
        throw InputError("plan", file, std::string("malformed: ") + e.what());
    }
}

}  // namespace mucosa::study
