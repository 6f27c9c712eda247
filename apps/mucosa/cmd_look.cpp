// mucosa look: the look fitted to a folder of a user's own real frames (fit),
// and the measurements it is fitted on: the realism statistics of frames
// (stats) and how far two sets are apart, by statistic and for a machine
// observer (compare). docs/look.md.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/image/png.hpp>
#include <mucosa/tune/look.hpp>

#include "progress_line.hpp"
#include "scene_options.hpp"

namespace mucosa::cli {

namespace {

namespace fs = std::filesystem;
using tune::FrameStat;

std::string num(double v) {
    if (!std::isfinite(v)) return "-";
    const double a = std::abs(v);
    return (a != 0 && (a < 0.01 || a >= 1e4)) ? fmt::format("{:.2e}", v) : fmt::format("{:.3f}", v);
}

// A set of frames: a folder of PNG frames or a statistics export; the file
// named in any error.
std::vector<tune::FrameStats> readSet(const std::string& path) {
    try {
        return tune::readFrameStats(path);
    } catch (const InputError& e) {
        if (e.file().empty()) throw InputError(e.subject(), path, e.reason());
        throw;
    }
}

// The per-statistic table of two summaries, the group means and the overall score.
void printComparison(const Global& g, const tune::FrameStatsSummary& real, const tune::FrameStatsSummary& ours,
                     const std::string& oursLabel) {
    const tune::RealismScore score = tune::realismScore(ours, real);
    info(g, fmt::format("{:<14} {:>10} {:>9} | {:>10} {:>9} | {:>7}", "statistic", "real", "IQR", oursLabel, "IQR",
                        "dist"));
    for (std::size_t k = 0; k < tune::kScoredStatCount; ++k) {
        const tune::StatSummary &r = real.stats[k], &y = ours.stats[k];
        info(g, fmt::format("{:<14} {:>10} {:>9} | {:>10} {:>9} | {:>7}", tune::info(static_cast<FrameStat>(k)).name,
                            r.n ? num(r.median) : "-", r.n ? num(r.iqr()) : "-", y.n ? num(y.median) : "-",
                            y.n ? num(y.iqr()) : "-", num(score.perStat[k])));
    }
    std::string groups;
    for (std::size_t gi = 0; gi < 4; ++gi)
        groups += fmt::format("{}{} {}", gi ? ", " : "", tune::groupName(static_cast<tune::StatGroup>(gi)),
                              num(score.perGroup[gi]));
    info(g, "groups: " + groups);
    info(g, fmt::format("realism score (mean of {} distances |median - real median| / real IQR, each at most 10): {}",
                        score.terms, num(score.overall)));
}

// The statistics that separate two sets most: |Cohen's d| with the pooled
// sample deviation, as observer.py prints them.
void printSeparating(const Global& g, const std::vector<tune::FrameStats>& real,
                     const std::vector<tune::FrameStats>& ours) {
    struct Row {
        double d;
        std::size_t k;
    };
    std::vector<Row> rows;
    for (std::size_t k = 0; k < tune::kScoredStatCount; ++k) {
        auto moments = [k](const std::vector<tune::FrameStats>& set, double& mean, double& var) {
            std::vector<double> v;
            for (const tune::FrameStats& f : set)
                if (!std::isnan(f.values[k])) v.push_back(f.values[k]);
            if (v.size() < 2) return false;
            mean = 0;
            for (double x : v) mean += x;
            mean /= static_cast<double>(v.size());
            var = 0;
            for (double x : v) var += (x - mean) * (x - mean);
            var /= static_cast<double>(v.size() - 1);
            return true;
        };
        double mr = 0, vr = 0, ms = 0, vs = 0;
        if (!moments(real, mr, vr) || !moments(ours, ms, vs)) continue;
        const double sp = std::sqrt((vr + vs) / 2);
        rows.push_back({std::abs(mr - ms) / (sp > 0 ? sp : 1e-9), k});
    }
    std::sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.d > b.d; });
    std::string line;
    for (std::size_t i = 0; i < rows.size() && i < 6; ++i)
        line +=
            fmt::format("{}{} {:.2f}", i ? ", " : "", tune::info(static_cast<FrameStat>(rows[i].k)).name, rows[i].d);
    info(g, "most separating statistics (|Cohen's d|): " + line);
}

struct FitArgs {
    SceneOptions scene;
    std::string frames, output, params, framesOut;
    int views = 16, size = 480, maxEvals = 300, patients = 0;
    double observerWeight = 1.0;
};

void runFit(const FitArgs& a, const Global& g) {
    const fs::path out = a.output;
    if (out.extension() != ".json") throw InputError("--output", out.string(), "must end in .json");
    const std::vector<tune::FrameStats> target = readSet(a.frames);
    if (target.size() < 2)
        throw InputError("frames", a.frames,
                         fmt::format("has {} frame: a fit needs at least 2 (20 or more to be "
                                     "representative)",
                                     target.size()));
    const scene::Scene scene = resolveScene(a.scene);
    tune::LookFitOptions o;
    for (const std::string& k : splitList(a.params)) o.params.emplace_back(tune::findTuneParam(k, "--params").key);
    o.probe.views = a.views;
    o.probe.patients = a.patients;
    o.probe.size = a.size;
    o.probe.threads = g.threads;
    o.maxEvaluations = a.maxEvals;
    o.observerWeight = a.observerWeight;
    requireWritable(out);
    fs::path reportPath = out;
    reportPath.replace_extension(".fit.json");
    if (!a.framesOut.empty()) requireOutputDir(a.framesOut);
    ProgressLine progress(g, "look");
    o.progress = [&](int done, int total, double best) {
        progress(done, total, fmt::format("best objective {:.3f}", best));
    };
    const tune::LookFitResult r = tune::fitLook(scene, target, o);
    progress.finish();

    const tune::FrameStatsSummary real = tune::summarise(target);
    printComparison(g, real, r.after.summary, "fitted");
    for (std::size_t i = 0; i < r.best.size(); ++i)
        info(g, fmt::format("{:<10} {} {} -> {}", tune::lookGroupName(tune::lookGroup(*r.best[i].first)),
                            r.best[i].first->key, num(r.start[i].second), num(r.best[i].second)));
    info(g,
         fmt::format("realism score {} -> {}, observer AUC {} -> {}, objective {} -> {} ({} of {} views)",
                     num(r.before.realism.overall), num(r.after.realism.overall), num(r.before.auc), num(r.after.auc),
                     num(r.before.objective), num(r.after.objective), count(r.evaluations, "render", "renders"),
                     a.patients > 0 ? fmt::format("{} x {}", a.patients + 1, a.views) : std::to_string(a.views)));

    writeFileAtomic(out, tune::presetJson(scene, r.best, false));
    auto summary = [](const tune::FrameStatsSummary& s) {
        nlohmann::json j = nlohmann::json::object();
        for (std::size_t k = 0; k < tune::kScoredStatCount; ++k) {
            const std::string name(tune::info(static_cast<FrameStat>(k)).name);
            j[name] = s.stats[k].n ? nlohmann::json{{"median", s.stats[k].median}, {"iqr", s.stats[k].iqr()}}
                                   : nlohmann::json(nullptr);
        }
        return j;
    };
    auto evaluation = [&](const tune::LookEvaluation& e) {
        nlohmann::json d = nlohmann::json::object();
        for (std::size_t k = 0; k < tune::kScoredStatCount; ++k)
            if (std::isfinite(e.realism.perStat[k]))
                d[std::string(tune::info(static_cast<FrameStat>(k)).name)] = e.realism.perStat[k];
        return nlohmann::json{{"objective", e.objective},
                              {"realism_score", e.realism.overall},
                              {"observer_auc", e.auc},
                              {"distance", d},
                              {"stats", summary(e.summary)}};
    };
    auto values = [](const tune::TuneValues& v) {
        nlohmann::json j = nlohmann::json::object();
        for (const auto& [p, x] : v) j[std::string(p->key)] = x;
        return j;
    };
    nlohmann::json rep;
    rep["frames"] = a.frames;
    rep["real_frames"] = target.size();
    rep["real_stats"] = summary(real);
    rep["start"] = values(r.start);
    rep["fitted"] = values(r.best);
    rep["before"] = evaluation(r.before);
    rep["after"] = evaluation(r.after);
    rep["evaluations"] = r.evaluations;
    rep["views"] = a.views;
    rep["patients"] = a.patients;
    rep["size"] = a.size;
    rep["observer_weight"] = a.observerWeight;
    writeFileAtomic(reportPath, rep.dump(1) + "\n");
    if (!a.framesOut.empty()) {
        std::error_code ec;
        fs::create_directory(a.framesOut, ec);
        for (std::size_t i = 0; i < r.frames.size(); ++i)
            image::writePng(fs::path(a.framesOut) / fmt::format("look_{:04}.png", i), r.frames[i]);
    }
    info(g,
         fmt::format(
             "wrote {} (render with --look {}) and {}{}", out.string(), out.string(), reportPath.string(),
             a.framesOut.empty() ? "" : fmt::format(", and the {} fitted views in {}", r.frames.size(), a.framesOut)));
}

// Every statistic of every frame (tab-separated), then the medians and IQRs.
void runStats(const std::vector<std::string>& inputs, const Global& g) {
    std::vector<std::string> columns;
    for (std::size_t k = 0; k < tune::kFrameStatCount; ++k)
        columns.emplace_back(tune::info(static_cast<FrameStat>(k)).name);
    std::vector<tune::FrameStats> frames;
    std::vector<std::pair<std::string, std::vector<double>>> rows;
    for (const std::string& in : inputs) {
        std::error_code ec;
        if (!fs::exists(in, ec)) throw IoError("frames", in, "no such file or folder");
        const std::vector<fs::path> files = fs::is_directory(in, ec) ? tune::listFrames(in) : std::vector<fs::path>{in};
        for (const fs::path& f : files) {
            frames.push_back(tune::measureFrameStatsFile(f));
            rows.push_back({f.filename().string(), {frames.back().values.begin(), frames.back().values.end()}});
        }
    }
    std::vector<StatColumn> summary;
    for (const tune::StatSummary& st : tune::summarise(frames).stats) summary.push_back({st.median, st.iqr(), st.n});
    printStatsTable(g, columns, rows, summary);
}

struct CompareArgs {
    std::string real, ours;
    int groups = 0;
};

void runCompare(const CompareArgs& a, const Global& g) {
    const std::vector<tune::FrameStats> real = readSet(a.real), ours = readSet(a.ours);
    printComparison(g, tune::summarise(real), tune::summarise(ours), "yours");
    const tune::ObserverResult obs = tune::logisticObserver(real, ours, a.groups);
    printSeparating(g, real, ours);
    info(g, fmt::format(
                "observer (logistic, cross-validated; {} real frames, {} of yours in {} held-out groups): "
                "AUC {:.3f} (0.5: cannot tell them apart, 1: tells them apart every time)",
                real.size(), ours.size(),
                std::min<std::size_t>(ours.size(), a.groups > 0 ? static_cast<std::size_t>(a.groups) : real.size()),
                obs.auc));
}

void addLookCommand(CLI::App& app, Global& g) {
    CLI::App* look = app.add_subcommand(
        "look",
        "Fit the look to a folder of your own real frames (fit); measure frames (stats) and how far two "
        "sets are apart (compare)");
    look->require_subcommand(1);

    auto f = std::make_shared<FitArgs>();
    CLI::App* fi = look->add_subcommand(
        "fit", "Search colour, vessels, mucus, highlights, exposure and camera for the frames closest to real ones");
    fi->footer(
        "Example: mucosa look fit my_scope_frames/ -o look.json, then mucosa render -o fly.png --frames 40 --look "
        "look.json\nObjective: realism score + observer weight x (observer AUC - 0.5) (docs/look.md).");
    fi->add_option("frames", f->frames,
                   "The real frames: a folder of PNG frames (<stem>.mask.png beside a frame masks it) or a "
                   "statistics export of realism_stats.py (.json)")
        ->required();
    addSceneOptions(fi, f->scene, false);
    fi->add_option("-o,--output", f->output,
                   "The look (.json: material, light, camera and tissue values; --look reads it); the report goes "
                   "beside it as <name>.fit.json")
        ->required();
    std::string keys;
    for (const tune::LookParam& p : tune::lookParams()) keys += (keys.empty() ? "" : ", ") + std::string(p.key);
    fi->add_option("--params", f->params, "Parameters searched, comma-separated [" + keys + "]");
    fi->add_option("--views", f->views, "Views along the scene's camera path [16]")->check(wholeNumber(2, 256));
    fi->add_option("--size", f->size,
                   "Views are NxN: the size you render at (the statistics see a frame's centre square at 320x320; 480 "
                   "is that of the default 640x480 frame) [480]")
        ->check(wholeNumber(16, 4096));
    fi->add_option("--patients", f->patients,
                   "Also fit over patients 1..N drawn about the look (--variation), --views each on its own survey: "
                   "the look becomes the centre of a varied dataset [0]")
        ->check(wholeNumber(0, 64));
    fi->add_option("--max-evals", f->maxEvals, "Renders of the view set at most [300]")->check(wholeNumber(1, 100000));
    fi->add_option("--observer-weight", f->observerWeight,
                   "Weight of the observer's AUC - 0.5 beside the realism score (0: the statistics alone) [1]")
        ->check(CLI::Range(0.0, 100.0));
    fi->add_option("--frames-out", f->framesOut, "Also write the fitted views here (look_0000.png, ...)");
    fi->callback([f, &g] { runFit(*f, g); });

    auto st = std::make_shared<std::vector<std::string>>();
    CLI::App* stc = look->add_subcommand(
        "stats", "Every realism statistic of PNG frames, per frame, then their median and IQR (realism_stats.py's)");
    stc->footer("Example: mucosa look stats frames/ > stats.tsv");
    stc->add_option("frames", *st, "PNG frames or folders of them (<stem>.mask.png beside a frame masks it)")
        ->required();
    stc->callback([st, &g] { runStats(*st, g); });

    auto c = std::make_shared<CompareArgs>();
    CLI::App* cc = look->add_subcommand(
        "compare", "How far your frames are from real ones: statistic by statistic, and for a machine observer");
    cc->footer("Example: mucosa look compare real_frames/ fly/");
    cc->add_option("real", c->real, "The real frames: a folder of PNG frames or a statistics export (.json)")
        ->required();
    cc->add_option("yours", c->ours, "Your frames: a folder of PNG frames or a statistics export (.json)")->required();
    cc->add_option("--groups", c->groups,
                   "Your frames are held out in this many contiguous groups (frames of one fly-through are alike) "
                   "[as many as the real frames]")
        ->check(wholeNumber(1, 100000));
    cc->callback([c, &g] { runCompare(*c, g); });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(76, addLookCommand);

}  // namespace mucosa::cli
