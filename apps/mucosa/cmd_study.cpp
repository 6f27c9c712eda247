// mucosa study: plan a perceptual realism study, run it in a browser, analyze it
// (the paper's user study, section "Visual assessment").
#include <pthread.h>

#include <csignal>
#include <cstdio>
#include <thread>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/study/analysis.hpp>
#include <mucosa/study/plan.hpp>
#include <mucosa/study/server.hpp>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

struct PlanArgs {
    std::string manifest, output;
    study::PlanOptions o;
};

struct ServeArgs {
    std::string plan, linksOut;
    study::ServeOptions o;
};

struct AnalyzeArgs {
    std::string input, twoafc, output;
};

void runPlan(const PlanArgs& a, const Global& g) {
    requireWritable(a.output);
    const study::Plan plan = study::makePlan(study::readManifest(a.manifest), a.o);
    const std::string fingerprint = study::writePlan(plan, a.output);
    const auto& first = plan.observers.front();
    const std::size_t likert = static_cast<std::size_t>(first.likertCount());
    info(g, fmt::format("wrote {}: {}, {}; each observer: calibration pair, {} (series of {}), {} (plan {})", a.output,
                        count(plan.observers.size(), "observer slot"), count(plan.images.size(), "image"),
                        count(likert, "Likert image"), plan.options.seriesLength,
                        count(first.trials.size() - 1 - likert, "2AFC pair"), fingerprint));
}

void runServe(const ServeArgs& a, const Global& g) {
    if (!a.linksOut.empty()) requireWritable(a.linksOut);
    study::Plan plan = study::readPlan(a.plan);
    const std::size_t slots = plan.observers.size();
    // SIGINT/SIGTERM stop the server cleanly: they are blocked in every thread
    // and one thread waits for them (no work inside a signal handler).
    sigset_t stopSignals;
    sigemptyset(&stopSignals);
    sigaddset(&stopSignals, SIGINT);
    sigaddset(&stopSignals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stopSignals, nullptr);
    study::StudyServer server(std::move(plan), a.o);
    std::thread waiter([&] {
        int sig = 0;
        sigwait(&stopSignals, &sig);
        server.stop();  // safe at any time, also before the server listens
    });
    try {
        server.run([&](int port) {
            // The links are the observers' credentials: in a 0600 file with
            // --links-out, else on stdout, one per slot, after this line.
            const std::vector<std::string> links = server.observerLinks(port);
            if (!a.linksOut.empty()) study::writeLinksFile(a.linksOut, links);
            info(g, fmt::format("serving the study on http://{}:{}/ ({}, answers in {}); {}; Ctrl-C stops", a.o.host,
                                port, count(slots, "observer slot"), a.o.db.string(),
                                a.linksOut.empty() ? "each observer opens their own link below"
                                                   : "observer links in " + a.linksOut));
            if (a.linksOut.empty())
                for (const std::string& l : links) std::fprintf(stdout, "%s\n", l.c_str());
            std::fflush(stdout);
        });
    } catch (...) {
        pthread_kill(waiter.native_handle(), SIGTERM);
        waiter.join();
        throw;
    }
    pthread_kill(waiter.native_handle(), SIGTERM);  // no-op if it already returned from sigwait
    waiter.join();
}

void runAnalyze(const AnalyzeArgs& a, const Global& g) {
    requireOutputDir(a.output);
    study::StudyData data = study::readStudyData(a.input);
    if (!a.twoafc.empty()) data.choices = study::readTwoAfcCsv(a.twoafc);
    const study::Analysis an = study::analyze(data);
    study::writeReport(an, a.output, a.input);
    study::writeCsv(data, a.output);
    for (const auto& w : an.warnings) warn(w);
    for (const auto& gr : an.groups) {
        std::string line = fmt::format("{}: {}", gr.group, count(gr.observers.size(), "observer"));
        if (gr.friedman.result)
            line += fmt::format(", Friedman chi2 = {:.3f} (df {}, p = {:.3g})", gr.friedman.result->chi2,
                                gr.friedman.result->df, gr.friedman.result->p);
        for (const auto& [c, r] : gr.roc) line += fmt::format(", AUC {} = {:.3f}", c, r.auc);
        info(g, line);
    }
    info(g, fmt::format("wrote {}, report.html, fig6_scores.svg, fig7_roc.svg, ratings.csv{}",
                        joinPath(a.output, "stats.json"), data.choices.empty() ? "" : ", pairs.csv"));
}

CLI::App* addAnalyzeCommand(CLI::App& study, const std::string& name, Global& g) {
    auto an = std::make_shared<AnalyzeArgs>();
    CLI::App* analyze = study.add_subcommand(name, "Statistics, HTML report and figures from the answers");
    analyze->footer(
        "Example: mucosa study analyze answers.sqlite -o report/\n"
        "         mucosa study analyze ratings.csv --twoafc pairs.csv -o report/");
    analyze->add_option("input", an->input, "answers.sqlite (from study serve) or ratings.csv")->required();
    analyze->add_option("--twoafc", an->twoafc,
                        "2AFC choices CSV (observer,group,left_category,right_category,"
                        "chosen_category); replaces the database's 2AFC answers");
    analyze->add_option("-o,--output", an->output, "Report folder (stats.json, report.html, SVG figures)")->required();
    analyze->callback([an, &g] { runAnalyze(*an, g); });
    return analyze;
}

void addStudyCommand(CLI::App& app, Global& g) {
    CLI::App* study = app.add_subcommand("study", "Perceptual realism study: plan, serve in a browser, analyze");
    study->require_subcommand(1);

    auto p = std::make_shared<PlanArgs>();
    CLI::App* plan = study->add_subcommand("plan", "Make a reproducible per-observer plan from an image manifest");
    plan->footer("Example: mucosa study plan --manifest images.json -o study.json --observers 30 --seed 7");
    plan->add_option("--manifest", p->manifest, "Image manifest (JSON: id, file, category 1-5, patient, pose)")
        ->required();
    plan->add_option("-o,--output", p->output, "Output plan (JSON)")->required();
    plan->add_option("--observers", p->o.observers, "Observer slots to plan [30]")->check(wholeNumber(1, 100000));
    plan->add_option("--seed", p->o.seed, "Random seed (same seed, same plan) [1]");
    plan->add_option("--series", p->o.seriesLength, "Likert images per series; a pause screen between series [15]")
        ->check(wholeNumber(1, 100000));
    plan->add_option("--likert", p->o.likertLimit,
                     "Likert images per observer, drawn evenly across categories; 0 = every image [0]")
        ->check(wholeNumber(0));
    plan->add_option("--twoafc", p->o.twoafcPerComparison,
                     "2AFC pairs per comparison (3 vs 4, 3 vs 5, 4 vs 5); 0 = no 2AFC [10]")
        ->check(wholeNumber(0, 10000));
    plan->callback([p, &g] { runPlan(*p, g); });

    auto sv = std::make_shared<ServeArgs>();
    CLI::App* serve = study->add_subcommand("serve", "Run the study in a browser; answers go to SQLite as given");
    serve->footer(
        "Example: mucosa study serve study.json --db answers.sqlite --port 8080 --links-out links.txt\n"
        "Each observer slot has a secret link (http://HOST:PORT/?t=TOKEN, the same at every restart);\n"
        "an observer opens their link, enters an id and group once; reloading resumes.");
    serve->add_option("plan", sv->plan, "Study plan from `mucosa study plan`")->required();
    serve->add_option("--db", sv->o.db, "Answers database (SQLite; created if missing, resumed if present)")
        ->required();
    serve->add_option("--port", sv->o.port, "TCP port; 0 = any free port [8080]")->check(wholeNumber(0, 65535));
    serve->add_option("--host", sv->o.host, "Address to listen on; 0.0.0.0 exposes it to the network [127.0.0.1]");
    serve->add_option("--links-out", sv->linksOut,
                      "Write the observer links here (mode 0600) instead of printing them");
    serve->add_option("--http-threads", sv->o.threads, "Request worker threads (they wait on SQLite commits) [8]")
        ->check(wholeNumber(1, 1024));
    serve->add_option("--max-connections", sv->o.maxConnections, "Open connections in total; more are closed [512]")
        ->check(wholeNumber(1, 100000));
    serve
        ->add_option("--client-connections", sv->o.maxClientConnections,
                     "Open connections from one address; raise it for observers behind one NAT [64]")
        ->check(wholeNumber(1, 100000));
    serve->callback([sv, &g] { runServe(*sv, g); });

    addAnalyzeCommand(*study, "analyze", g);
    // The British spelling still runs, unlisted (CLI11 lists an alias in --help).
    addAnalyzeCommand(*study, "analyse", g)->group("");
}

}  // namespace

MUCOSA_REGISTER_COMMAND(90, addStudyCommand);

}  // namespace mucosa::cli
