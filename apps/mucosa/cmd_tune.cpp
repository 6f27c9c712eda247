// mucosa tune: how the reflectance map's noise and the specular lobe shape
// the highlights (sweep), and a look fitted to target highlight statistics
// (fit). docs/tune.md.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/tune/tune.hpp>

#include "progress_line.hpp"
#include "scene_options.hpp"

namespace mucosa::cli {

namespace {

namespace fs = std::filesystem;

struct ProbeArgs {
    SceneOptions scene;
    std::string params;
    int views = 8;
    int size = 320;
};

struct SweepArgs {
    ProbeArgs probe;
    std::string output, target;
    int steps = 7;
};

struct FitArgs {
    ProbeArgs probe;
    std::string output, target, stats;
    int maxEvals = 80;
};

// The keys of --params, checked (each must be a tunable parameter), with their groups.
std::vector<std::string> paramKeys(const std::string& list) {
    std::vector<std::string> keys;
    for (const std::string& k : splitList(list)) keys.emplace_back(tune::findTuneParam(k, "--params").key);
    return keys;
}

tune::ProbeOptions probeOptions(const ProbeArgs& a, const Global& g) {
    tune::ProbeOptions o;
    o.views = a.views;
    o.size = a.size;
    o.threads = g.threads;
    return o;
}

std::string fmtStat(double v) {
    if (!std::isfinite(v)) return "-";
    const double a = std::abs(v);
    return (a != 0 && (a < 0.01 || a >= 1e4)) ? fmt::format("{:.2e}", v) : fmt::format("{:.3f}", v);
}

void runSweep(const SweepArgs& a, const Global& g) {
    const scene::Scene scene = resolveScene(a.probe.scene);
    tune::SweepOptions o;
    o.params = paramKeys(a.probe.params);
    o.steps = a.steps;
    o.probe = probeOptions(a.probe, g);
    std::optional<tune::HighlightSummary> target;
    if (!a.target.empty()) target = tune::summarise(tune::readTargetFrames(a.target));
    requireOutputDir(a.output);  // before the work, not after it
    std::error_code ec;
    fs::create_directory(a.output, ec);
    if (ec) throw IoError("output folder", a.output, ec.message());
    ProgressLine progress(g, "tune");
    o.progress = [&](int done, int total) { progress(done, total, "sweeping"); };
    const tune::SweepResult r = tune::sweep(scene, o);
    const fs::path dir = a.output;
    writeFileAtomic(dir / "sweep.tsv", tune::sweepTsv(r));
    writeFileAtomic(dir / "sweep.json", tune::sweepJson(r, target ? &*target : nullptr));
    for (int k = 0; k < tune::kHighlightStatCount; ++k) {
        const auto stat = static_cast<tune::HighlightStat>(k);
        writeFileAtomic(dir / fmt::format("sweep_{}.svg", tune::statName(stat)),
                        tune::sweepSvg(r, stat, target ? &*target : nullptr));
    }
    // The relationship in one line per parameter: each statistic's median at
    // the lowest and the highest value swept.
    for (const tune::TuneParam* p : r.params) {
        const tune::SweepPoint *lo = nullptr, *hi = nullptr;
        for (const tune::SweepPoint& pt : r.points)
            if (pt.param == p) {
                if (lo == nullptr) lo = &pt;
                hi = &pt;
            }
        std::string line = fmt::format("{} {} -> {}:", p->key, fmtStat(lo->value), fmtStat(hi->value));
        for (int k = 0; k < tune::kHighlightStatCount; ++k)
            line += fmt::format(" {} {} -> {}", tune::statName(static_cast<tune::HighlightStat>(k)),
                                fmtStat(lo->summary.stats[static_cast<std::size_t>(k)].median),
                                fmtStat(hi->summary.stats[static_cast<std::size_t>(k)].median));
        info(g, line);
    }
    info(g, fmt::format("wrote {}, sweep.json and {} plots sweep_<statistic>.svg ({} x {} views at {}x{})",
                        joinPath(dir, "sweep.tsv"), tune::kHighlightStatCount, count(r.points.size(), "setting"),
                        r.views, r.size, r.size));
}

void runFit(const FitArgs& a, const Global& g) {
    const scene::Scene scene = resolveScene(a.probe.scene);
    const fs::path out = a.output;
    if (out.extension() != ".json") throw InputError("--output", out.string(), "must end in .json");
    tune::TuneFitOptions o;
    o.params = paramKeys(a.probe.params);
    for (const std::string& s : splitList(a.stats)) {
        tune::HighlightStat st{};
        if (!tune::findStat(s, st)) {
            std::string known;
            for (int k = 0; k < tune::kHighlightStatCount; ++k)
                known += (k ? ", " : "") + std::string(tune::statName(static_cast<tune::HighlightStat>(k)));
            throw InputError("--stats", "", fmt::format("unknown statistic '{}' (known: {})", s, known));
        }
        o.stats.push_back(st);
    }
    o.probe = probeOptions(a.probe, g);
    o.maxEvaluations = a.maxEvals;
    const tune::HighlightSummary target = [&] {
        try {
            return tune::summarise(tune::readTargetFrames(a.target));
        } catch (const InputError& e) {
            if (e.file().empty()) throw InputError(e.subject(), a.target, e.reason());
            throw;
        }
    }();
    requireWritable(out);
    fs::path reportPath = out;
    reportPath.replace_extension(".tune.json");
    ProgressLine progress(g, "tune");
    o.progress = [&](int done, int total, double best) {
        progress(done, total, fmt::format("best distance {:.3f}", best));
    };
    const tune::TuneFitResult r = tune::fitToTarget(scene, target, o);
    progress.finish();

    info(g, fmt::format("{:<14} {:>10} {:>10} | {:>10} {:>7} | {:>10} {:>7}", "statistic", "target", "IQR", "before",
                        "dist", "after", "dist"));
    for (int k = 0; k < tune::kHighlightStatCount; ++k) {
        const auto s = static_cast<tune::HighlightStat>(k);
        const auto i = static_cast<std::size_t>(k);
        info(g, fmt::format("{:<14} {:>10} {:>10} | {:>10} {:>7} | {:>10} {:>7}", tune::statName(s),
                            fmtStat(target[s].median), target[s].n ? fmtStat(target[s].iqr()) : "-",
                            fmtStat(r.beforeSummary[s].median), fmtStat(r.before.perStat[i]),
                            fmtStat(r.afterSummary[s].median), fmtStat(r.after.perStat[i])));
    }
    std::string sets;
    for (std::size_t i = 0; i < r.best.size(); ++i)
        info(g,
             fmt::format("{} {} -> {}", r.best[i].first->key, fmtStat(r.start[i].second), fmtStat(r.best[i].second)));
    for (const auto& [p, v] : r.best) sets += fmt::format(" --set {}={:.6g}", p->key, v);
    info(g, fmt::format("distance (sum over {} of |median - target| / target IQR): before {:.3f}, after {:.3f} ({})",
                        count(r.after.terms, "statistic"), r.before.total, r.after.total,
                        count(r.evaluations, "render", "renders") + " of the view set"));

    writeFileAtomic(out, tune::presetJson(scene, r.best));
    nlohmann::json rep;
    auto summary = [](const tune::HighlightSummary& s) {
        nlohmann::json j = nlohmann::json::object();
        for (int k = 0; k < tune::kHighlightStatCount; ++k) {
            const auto st = static_cast<tune::HighlightStat>(k);
            if (s[st].n == 0) {
                j[std::string(tune::statName(st))] = nullptr;
                continue;
            }
            j[std::string(tune::statName(st))] = {{"median", s[st].median}, {"iqr", s[st].iqr()}, {"n", s[st].n}};
        }
        return j;
    };
    auto values = [](const tune::TuneValues& v) {
        nlohmann::json j = nlohmann::json::object();
        for (const auto& [p, x] : v) j[std::string(p->key)] = x;
        return j;
    };
    auto perStat = [](const tune::Distance& d) {
        nlohmann::json j = nlohmann::json::object();
        for (int k = 0; k < tune::kHighlightStatCount; ++k)
            if (std::isfinite(d.perStat[static_cast<std::size_t>(k)]))
                j[std::string(tune::statName(static_cast<tune::HighlightStat>(k)))] =
                    d.perStat[static_cast<std::size_t>(k)];
        return j;
    };
    rep["target"] = a.target;
    rep["target_stats"] = summary(target);
    rep["start"] = values(r.start);
    rep["fitted"] = values(r.best);
    rep["before"] = {
        {"distance", r.before.total}, {"per_stat", perStat(r.before)}, {"stats", summary(r.beforeSummary)}};
    rep["after"] = {{"distance", r.after.total}, {"per_stat", perStat(r.after)}, {"stats", summary(r.afterSummary)}};
    rep["evaluations"] = r.evaluations;
    rep["views"] = a.probe.views;
    rep["size"] = a.probe.size;
    writeFileAtomic(reportPath, rep.dump(1) + "\n");
    info(g, fmt::format("wrote {} (reflectance_map and material: merge them into a scene file, or render with{}) "
                        "and {}",
                        out.string(), sets, reportPath.string()));
}

// Per-frame statistics of PNG frames (files or folders), then their medians
// and IQRs: the realism tool's numbers, from C++.
void runStats(const std::vector<std::string>& inputs, const Global& g) {
    std::vector<fs::path> files;
    for (const std::string& in : inputs) {
        std::error_code ec;
        if (!fs::exists(in, ec)) throw IoError("frames", in, "no such file or folder");
        if (fs::is_directory(in, ec)) {
            const std::vector<fs::path> f = tune::listFrames(in);
            files.insert(files.end(), f.begin(), f.end());
        } else {
            files.emplace_back(in);
        }
    }
    std::vector<std::string> columns;
    for (int k = 0; k < tune::kHighlightStatCount; ++k)
        columns.emplace_back(tune::statName(static_cast<tune::HighlightStat>(k)));
    std::vector<tune::FrameHighlights> frames;
    std::vector<std::pair<std::string, std::vector<double>>> rows;
    for (const fs::path& f : files) {
        frames.push_back(tune::measureFrameFile(f));
        rows.push_back({f.filename().string(), {frames.back().values.begin(), frames.back().values.end()}});
    }
    std::vector<StatColumn> summary;
    for (const tune::StatSummary& st : tune::summarise(frames).stats) summary.push_back({st.median, st.iqr(), st.n});
    printStatsTable(g, columns, rows, summary);
}

void addProbeOptions(CLI::App* c, ProbeArgs& a) {
    addSceneOptions(c, a.scene, false);
    std::string keys;
    for (const tune::TuneParam& p : tune::tuneParams()) keys += (keys.empty() ? "" : ", ") + std::string(p.key);
    c->add_option("--params", a.params,
                  "Parameters, comma-separated, with or without their group (" + keys + ") [the first six]");
    c->add_option("--views", a.views, "Views along the scene's camera path [8]")->check(wholeNumber(1, 64));
    c->add_option("--size", a.size, "Frames are NxN (measured at 320x320, as the realism tool) [320]")
        ->check(wholeNumber(16, 4096));
}

void addTuneCommand(CLI::App& app, Global& g) {
    CLI::App* tune = app.add_subcommand(
        "tune",
        "How the map's noise and the specular lobe shape the highlights (sweep); a look fitted to target "
        "highlight statistics (fit)");
    tune->require_subcommand(1);

    auto s = std::make_shared<SweepArgs>();
    CLI::App* sw = tune->add_subcommand(
        "sweep", "Vary each parameter over its range (the others at the scene's values) and measure the highlights");
    sw->footer(
        "Example: mucosa tune sweep -o sweep/ --steps 7 --views 8 --target ../shared/realism/real_dev_stats.json\n"
        "Writes sweep.tsv, sweep.json and one SVG per statistic (docs/tune.md).");
    addProbeOptions(sw, s->probe);
    sw->add_option("-o,--output", s->output, "Output folder (sweep.tsv, sweep.json, sweep_<statistic>.svg)")
        ->required();
    sw->add_option("--steps", s->steps, "Values per parameter, plus the scene's own [7]")->check(wholeNumber(2, 64));
    sw->add_option("--target", s->target,
                   "Target statistics drawn in the plots: a realism_stats.py export (.json) or a folder of PNG frames");
    sw->callback([s, &g] { runSweep(*s, g); });

    auto f = std::make_shared<FitArgs>();
    CLI::App* fi = tune->add_subcommand(
        "fit", "Search the parameters for the highlights closest to a target (sum of |median - target| / IQR)");
    fi->footer(
        "Example: mucosa tune fit --target ../shared/realism/real_dev_stats.json -o bronchial_fit.json\n"
        "Then merge its reflectance_map and material into a scene file, or use the --set options it prints.");
    addProbeOptions(fi, f->probe);
    fi->add_option("--target", f->target,
                   "Target: a realism_stats.py export (.json, per-frame statistics) or a folder of PNG frames")
        ->required();
    fi->add_option("-o,--output", f->output,
                   "Preset (.json: a scene fragment with reflectance_map and material); the report goes beside it "
                   "as <name>.tune.json")
        ->required();
    fi->add_option("--stats", f->stats, "Statistics summed, comma-separated (hl_frac, hl_count, ...) [all eight]");
    fi->add_option("--max-evals", f->maxEvals, "Renders of the view set at most [80]")->check(wholeNumber(1, 100000));
    fi->callback([f, &g] { runFit(*f, g); });

    auto st = std::make_shared<std::vector<std::string>>();
    CLI::App* stc = tune->add_subcommand(
        "stats", "Highlight statistics of PNG frames, per frame and their median and IQR (realism_stats.py's)");
    stc->footer("Example: mucosa tune stats frames/ > stats.tsv");
    stc->add_option("frames", *st, "PNG frames or folders of them (<stem>.mask.png beside a frame masks it)")
        ->required();
    stc->callback([st, &g] { runStats(*st, g); });
}

}  // namespace

MUCOSA_REGISTER_COMMAND(75, addTuneCommand);

}  // namespace mucosa::cli
