// stats.json, the HTML report and the two figures (the paper's Fig. 6 and 7),
// all text: SVG is drawn by hand, so no plotting library is needed.
#include <mucosa/study/analysis.hpp>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/core/text.hpp>
#include <mucosa/study/plan.hpp>

namespace mucosa::study {

namespace fs = std::filesystem;
using nlohmann::json;
using nlohmann::ordered_json;

namespace {

const char* const kConventions[] = {
    "groups: 'all' and each group present ('naive', 'expert'); category 5 (real frames) is the reference",
    "categories.<c>: n_ratings, mean, sd = sample SD (n-1, null for one rating), n_observers = observers with at "
    "least one rating of c",
    "friedman: blocks = observers, treatments = categories, value = the observer's mean score in the category; "
    "Friedman 1937 with the tie correction, = scipy.stats.friedmanchisquare(*columns); kendalls_w = chi2/(n (k-1)); "
    "observers without a rating in every category are left out and listed in excluded_observers",
    "wilcoxon.<c>: category c vs 5 paired by observer means, d = mean_c - mean_5, zero differences dropped; "
    "T = min(W+, W-), z = normal approximation with tie-corrected variance and no continuity correction, p two-sided "
    "= scipy.stats.wilcoxon(x, y, zero_method='wilcox', correction=False, method='approx'); p_exact only when no "
    "difference is zero and no |d| is tied (= method='exact')",
    "roc.<c>: 'synthetic if score <= t' for t = 0..5, positives = ratings of c, negatives = ratings of 5; points "
    "are [fpr, tpr]; auc by the trapezoid rule = P(pos < neg) + P(pos = neg)/2; observer_auc = the same area from "
    "each observer's own ratings (order of 'observers'; null without ratings of both), with its mean and sample SD",
    "twoafc.<a>_vs_<b> (a < b): proportion of choices of the higher category b; p = exact two-sided binomial test "
    "against 0.5 (scipy.stats.binomtest); ci95_wilson = Wilson score interval without continuity correction",
    "naive_vs_expert.<c>: scipy.stats.mannwhitneyu(naive, expert, alternative='two-sided', method='asymptotic', "
    "use_continuity=True), U of the naive sample; on observer means and on single ratings",
};

ordered_json optionalNumber(const std::optional<double>& v) {
    return v ? ordered_json(*v) : ordered_json(nullptr);
}

template <class R>
void addExclusions(ordered_json& j, const Outcome<R>& o) {
    j["excluded_observers"] = o.excludedObservers;
    if (!o.result) j["reason"] = o.why;
}

ordered_json mannWhitneyJson(const Outcome<MannWhitneyResult>& o) {
    ordered_json j;
    if (o.result) {
        j = {{"U", o.result->U},
             {"z", o.result->z},
             {"p", o.result->p},
             {"n_naive", o.result->n1},
             {"n_expert", o.result->n2}};
    } else {
        j = {{"U", nullptr}, {"p", nullptr}, {"reason", o.why}};
    }
    return j;
}

ordered_json groupJson(const GroupAnalysis& g) {
    ordered_json j;
    j["observers"] = g.observers;
    j["n_observers"] = g.observers.size();
    ordered_json cats = ordered_json::object();
    for (const auto& [c, s] : g.categories)
        cats[std::to_string(c)] = {
            {"n_ratings", s.nRatings}, {"mean", s.mean}, {"sd", optionalNumber(s.sd)}, {"n_observers", s.nObservers}};
    j["categories"] = cats;

    ordered_json f;
    if (g.friedman.result) {
        const FriedmanResult& r = *g.friedman.result;
        f = {{"chi2", r.chi2},
             {"df", r.df},
             {"p", r.p},
             {"n_blocks", r.nBlocks},
             {"kendalls_w", r.kendallsW},
             {"k", r.k},
             {"ln_p", r.lnP},
             {"chi2_uncorrected", r.chi2Uncorrected},
             {"tie_correction", r.tieCorrection},
             {"rank_sums", r.rankSums}};
    } else {
        f = {{"chi2", nullptr},
             {"df", nullptr},
             {"p", nullptr},
             {"n_blocks", g.observerMeans.size()},
             {"kendalls_w", nullptr}};
    }
    addExclusions(f, g.friedman);
    j["friedman"] = f;

    ordered_json w = ordered_json::object();
    for (const auto& [c, o] : g.wilcoxon) {
        ordered_json e;
        if (o.result) {
            const WilcoxonResult& r = *o.result;
            e = {{"T", r.T},          {"z", r.z},          {"p", r.p},           {"n", r.n}, {"n_pairs", r.nPairs},
                 {"n_zero", r.nZero}, {"w_plus", r.wPlus}, {"w_minus", r.wMinus}};
            if (r.pExact) e["p_exact"] = *r.pExact;
        } else {
            e = {{"T", nullptr}, {"z", nullptr}, {"p", nullptr}, {"n", 0}};
        }
        addExclusions(e, o);
        w[std::to_string(c)] = e;
    }
    j["wilcoxon"] = w;

    ordered_json rocs = ordered_json::object();
    for (const auto& [c, r] : g.roc) {
        ordered_json pts = ordered_json::array();
        for (const auto& p : r.points) pts.push_back({p[0], p[1]});
        rocs[std::to_string(c)] = {{"points", pts}, {"auc", r.auc}, {"n_pos", r.nPos}, {"n_neg", r.nNeg}};
        if (auto it = g.observerAuc.find(c); it != g.observerAuc.end()) {
            ordered_json v = ordered_json::array();
            for (const auto& x : it->second.values) v.push_back(optionalNumber(x));
            rocs[std::to_string(c)]["observer_auc"] = v;
            rocs[std::to_string(c)]["observer_auc_mean"] = optionalNumber(it->second.mean);
            rocs[std::to_string(c)]["observer_auc_sd"] = optionalNumber(it->second.sd);
        }
    }
    j["roc"] = rocs;

    ordered_json t = ordered_json::object();
    for (const auto& [key, b] : g.twoafc)
        t[fmt::format("{}_vs_{}", key.first, key.second)] = {
            {"n", b.n}, {"k", b.k}, {"proportion", b.proportion}, {"p", b.p}, {"ci95_wilson", {b.ciLow, b.ciHigh}}};
    j["twoafc"] = t;
    return j;
}

std::string esc(const std::string& s) {
    return escapeXml(s);
}

const char* groupColour(const std::string& g) {
    if (g == "naive") return "#4C78A8";
    if (g == "expert") return "#E45756";
    return "#7F7F7F";
}

const char* categoryColour(int c) {
    static const char* k[] = {"#000000", "#D62728", "#FF7F0E", "#2CA02C", "#1F77B4", "#9467BD"};
    return k[std::clamp(c, 0, 5)];
}

const char* categoryLabel(int c) {
    switch (c) {
        case 1:
            return "1 unreal";
        case 2:
            return "2 low-res texture";
        case 3:
            return "3 BRDF, no specular";
        case 4:
            return "4 BRDF + noise specular";
        case 5:
            return "5 real frame";
    }
    return "?";
}

// Fig. 6: mean Likert score per category and group, bars with +-1 SD.
std::string fig6Svg(const Analysis& a) {
    const double W = 680, H = 380, left = 50, right = 150, top = 30, bottom = 50;
    const double plotW = W - left - right, plotH = H - top - bottom;
    auto y = [&](double v) { return top + plotH * (1 - v / 5.5); };
    std::string s = fmt::format(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" viewBox=\"0 0 {} {}\" "
        "font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
        "<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"14\">Mean realism score per category (bars: "
        "&#177;1 SD)</text>\n",
        W, H, W, H, left + plotW / 2);
    for (int v = 0; v <= 5; ++v)
        s += fmt::format(
            "<line x1=\"{}\" x2=\"{}\" y1=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"#ddd\"/><text x=\"{}\" "
            "y=\"{:.1f}\" text-anchor=\"end\">{}</text>\n",
            left, left + plotW, y(v), y(v), left - 6, y(v) + 4, v);
    const std::size_t nc = a.categories.size(), ng = a.groups.size();
    const double slot = plotW / static_cast<double>(nc), barW = slot * 0.8 / static_cast<double>(ng);
    for (std::size_t ci = 0; ci < nc; ++ci) {
        const int c = a.categories[ci];
        const double x0 = left + slot * static_cast<double>(ci) + slot * 0.1;
        s += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", x0 + slot * 0.4,
                         top + plotH + 18, c);
        for (std::size_t gi = 0; gi < ng; ++gi) {
            const auto& g = a.groups[gi];
            auto it = g.categories.find(c);
            if (it == g.categories.end()) continue;
            const double m = it->second.mean, sd = it->second.sd.value_or(0);
            const double bx = x0 + barW * static_cast<double>(gi);
            s += fmt::format(
                "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"{}\"><title>{} "
                "category {}: {:.3f} &#177; {:.3f}</title></rect>\n",
                bx, y(m), barW * 0.9, y(0) - y(m), groupColour(g.group), g.group, c, m, sd);
            const double cx = bx + barW * 0.45, lo = std::max(0.0, m - sd), hi = std::min(5.5, m + sd);
            s += fmt::format(
                "<path d=\"M{0:.1f} {1:.1f}V{2:.1f}M{3:.1f} {1:.1f}H{4:.1f}M{3:.1f} {2:.1f}H{4:.1f}\" "
                "stroke=\"black\" fill=\"none\"/>\n",
                cx, y(lo), y(hi), cx - barW * 0.2, cx + barW * 0.2);
        }
    }
    s +=
        fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">image category</text>\n", left + plotW / 2, H - 12);
    s += fmt::format(
        "<text transform=\"translate(14 {}) rotate(-90)\" text-anchor=\"middle\">Likert score "
        "(1-5)</text>\n",
        top + plotH / 2);
    for (std::size_t gi = 0; gi < ng; ++gi) {
        const double ly = top + 10 + 20 * static_cast<double>(gi);
        s += fmt::format(
            "<rect x=\"{}\" y=\"{}\" width=\"12\" height=\"12\" fill=\"{}\"/><text x=\"{}\" y=\"{}\">{} "
            "(n={})</text>\n",
            W - right + 15, ly, groupColour(a.groups[gi].group), W - right + 32, ly + 10, a.groups[gi].group,
            a.groups[gi].observers.size());
    }
    for (std::size_t ci = 0; ci < nc; ++ci)
        s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"10\" fill=\"#555\">{}</text>\n", W - right + 15,
                         top + 90 + 14 * static_cast<double>(ci), categoryLabel(a.categories[ci]));
    return s + "</svg>\n";
}

// Fig. 7: ROC of each synthetic category against the real frames, one panel per group.
std::string fig7Svg(const Analysis& a) {
    const double panel = 260, pad = 45, top = 30;
    const double W = static_cast<double>(a.groups.size()) * (panel + pad) + pad + 200, H = panel + top + 60;
    std::string s = fmt::format(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" viewBox=\"0 0 {} {}\" "
        "font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
        W, H, W, H);
    for (std::size_t gi = 0; gi < a.groups.size(); ++gi) {
        const auto& g = a.groups[gi];
        const double x0 = pad + static_cast<double>(gi) * (panel + pad), y0 = top;
        auto px = [&](double f) { return x0 + f * panel; };
        auto py = [&](double t) { return y0 + (1 - t) * panel; };
        s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"14\">{} (n={})</text>\n",
                         x0 + panel / 2, y0 - 10, g.group, g.observers.size());
        s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#888\"/>\n", x0, y0,
                         panel, panel);
        for (int t = 1; t < 5; ++t) {
            const double f = t / 5.0;
            s += fmt::format("<path d=\"M{:.1f} {:.1f}V{:.1f}M{:.1f} {:.1f}H{:.1f}\" stroke=\"#eee\"/>\n", px(f), py(0),
                             py(1), px(0), py(f), px(1));
        }
        s += fmt::format("<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"#999\" stroke-dasharray=\"5 4\"/>\n",
                         px(0), py(0), px(1), py(1));
        for (const auto& [c, r] : g.roc) {
            std::string d;
            for (std::size_t i = 0; i < r.points.size(); ++i)
                d += fmt::format("{}{:.1f} {:.1f}", i ? "L" : "M", px(r.points[i][0]), py(r.points[i][1]));
            s += fmt::format("<path d=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"2\"/>\n", d, categoryColour(c));
            for (const auto& p : r.points)
                s += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.5\" fill=\"{}\"/>\n", px(p[0]), py(p[1]),
                                 categoryColour(c));
        }
        for (int t = 0; t <= 5; t += 1) {
            const double f = t / 5.0;
            s += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\" font-size=\"10\">{:.1f}</text>\n",
                             px(f), py(0) + 14, f);
            s += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"end\" font-size=\"10\">{:.1f}</text>\n",
                             px(0) - 4, py(f) + 3, f);
        }
        s += fmt::format(
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">false positives (real called "
            "synthetic)</text>\n",
            x0 + panel / 2, y0 + panel + 32);
        if (gi == 0)
            s += fmt::format(
                "<text transform=\"translate(12 {}) rotate(-90)\" text-anchor=\"middle\">true positives "
                "(synthetic called synthetic)</text>\n",
                y0 + panel / 2);
    }
    const double lx = pad + static_cast<double>(a.groups.size()) * (panel + pad);
    int row = 0;
    for (int c : a.categories) {
        if (c == kReferenceCategory) continue;
        std::string aucs;
        for (const auto& g : a.groups)
            if (auto it = g.roc.find(c); it != g.roc.end())
                aucs += fmt::format("{}{:.2f}", aucs.empty() ? " " : ", ", it->second.auc);
        s += fmt::format(
            "<line x1=\"{}\" x2=\"{}\" y1=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"3\"/><text x=\"{}\" "
            "y=\"{}\">{}</text><text x=\"{}\" y=\"{}\" font-size=\"10\" fill=\"#555\">AUC by panel:{}</text>\n",
            lx, lx + 18, top + 20 + 34 * row, top + 20 + 34 * row, categoryColour(c), lx + 24, top + 24 + 34 * row,
            categoryLabel(c), lx + 24, top + 37 + 34 * row, aucs);
        ++row;
    }
    s += fmt::format(
        "<line x1=\"{}\" x2=\"{}\" y1=\"{}\" y2=\"{}\" stroke=\"#999\" stroke-dasharray=\"5 4\"/><text "
        "x=\"{}\" y=\"{}\">random classifier</text>\n",
        lx, lx + 18, top + 20 + 34 * row, top + 20 + 34 * row, lx + 24, top + 24 + 34 * row);
    return s + "</svg>\n";
}

std::string num(double v, int digits = 3) {
    return fmt::format("{:.{}f}", v, digits);
}
std::string pval(double p) {
    return p < 1e-4 ? fmt::format("{:.2e}", p) : fmt::format("{:.4f}", p);
}

std::string reportHtml(const Analysis& a, const std::string& source, const std::string& fig6, const std::string& fig7) {
    std::string h =
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>Mucosa realism study "
        "report</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
        "table{border-collapse:collapse;margin:.5em 0 1.5em}td,th{border:1px solid #ccc;padding:3px 8px;"
        "text-align:right}th{background:#f3f3f3}.warn{color:#a60}</style></head><body>\n";
    h += fmt::format(
        "<h1>Realism study report</h1>\n<p>Source: <code>{}</code>. Full numbers in "
        "<code>stats.json</code>.</p>\n",
        esc(source));
    for (const auto& w : a.warnings) h += "<p class=\"warn\">Note: " + esc(w) + "</p>\n";
    h += "<h2>Scores per category (Fig. 6)</h2>\n" + fig6;
    for (const auto& g : a.groups) {
        h += fmt::format(
            "<h2>Group {} ({} {})</h2>\n<table><tr><th>category</th><th>ratings</th><th>observers"
            "</th><th>mean</th><th>SD</th><th>Wilcoxon vs 5: T</th><th>z</th><th>p</th><th>n</th>"
            "<th>ROC AUC</th><th>observer AUC mean &#177; SD</th></tr>\n",
            esc(g.group), g.observers.size(), g.observers.size() == 1 ? "observer" : "observers");
        for (const auto& [c, s] : g.categories) {
            h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>", esc(categoryLabel(c)),
                             s.nRatings, s.nObservers, num(s.mean), s.sd ? num(*s.sd) : "-");
            auto w = g.wilcoxon.find(c);
            if (w != g.wilcoxon.end() && w->second.result)
                h += fmt::format("<td>{}</td><td>{}</td><td>{}</td><td>{}</td>", num(w->second.result->T, 1),
                                 num(w->second.result->z), pval(w->second.result->p), w->second.result->n);
            else
                h += "<td colspan=\"4\">-</td>";
            auto r = g.roc.find(c);
            h += fmt::format("<td>{}</td>", r != g.roc.end() ? num(r->second.auc) : "-");
            auto oa = g.observerAuc.find(c);
            h += fmt::format("<td>{}</td></tr>\n",
                             oa != g.observerAuc.end() && oa->second.mean
                                 ? num(*oa->second.mean) + " &#177; " + num(oa->second.sd.value_or(0))
                                 : "-");
        }
        h += "</table>\n";
        if (g.friedman.result)
            h += fmt::format(
                "<p>Friedman (observer means): &chi;&sup2; = {}, df = {}, p = {}, n = {}, Kendall's W = "
                "{}</p>\n",
                num(g.friedman.result->chi2), g.friedman.result->df, pval(g.friedman.result->p),
                g.friedman.result->nBlocks, num(g.friedman.result->kendallsW));
        else
            h += "<p>Friedman: not computed (" + esc(g.friedman.why) + ")</p>\n";
        if (!g.twoafc.empty()) {
            h += "<table><tr><th>2AFC</th><th>n</th><th>chose higher</th><th>95% CI (Wilson)</th><th>p "
                 "(binomial)</th></tr>\n";
            for (const auto& [k, b] : g.twoafc)
                h += fmt::format(
                    "<tr><td>{} vs {}</td><td>{}</td><td>{:.1f}%</td><td>{:.1f}-{:.1f}%</td><td>{}</td>"
                    "</tr>\n",
                    k.first, k.second, b.n, 100 * b.proportion, 100 * b.ciLow, 100 * b.ciHigh, pval(b.p));
            h += "</table>\n";
        }
    }
    if (!a.naiveVsExpert.empty()) {
        h += "<h2>Naive vs expert (Mann-Whitney, two-sided)</h2>\n<table><tr><th>category</th><th>U (observer "
             "means)</th><th>p</th><th>U (ratings)</th><th>p</th></tr>\n";
        for (const auto& [c, gc] : a.naiveVsExpert) {
            auto cell = [](const Outcome<MannWhitneyResult>& o) {
                return o.result ? fmt::format("<td>{}</td><td>{}</td>", num(o.result->U, 1), pval(o.result->p))
                                : std::string("<td colspan=\"2\">-</td>");
            };
            h += fmt::format("<tr><td>{}</td>{}{}</tr>\n", esc(categoryLabel(c)), cell(gc.observerMeans),
                             cell(gc.ratings));
        }
        h += "</table>\n";
    }
    h += "<h2>ROC curves (Fig. 7)</h2>\n" + fig7 + "</body></html>\n";
    return h;
}

}  // namespace

std::string statsJson(const Analysis& a, const std::string& source) {
    ordered_json j;
    ordered_json meta;
    meta["format"] = "mucosa-study-stats";
    meta["version"] = 1;
    meta["source"] = source;
    meta["categories"] = a.categories;
    meta["groups"] = ordered_json::array();
    for (const auto& g : a.groups) meta["groups"].push_back(g.group);
    meta["warnings"] = a.warnings;
    meta["conventions"] = kConventions;
    j["meta"] = meta;
    for (const auto& g : a.groups) j[g.group] = groupJson(g);
    if (!a.naiveVsExpert.empty()) {
        ordered_json nve = ordered_json::object();
        for (const auto& [c, gc] : a.naiveVsExpert)
            nve[std::to_string(c)] = {{"observer_means", mannWhitneyJson(gc.observerMeans)},
                                      {"ratings", mannWhitneyJson(gc.ratings)}};
        j["naive_vs_expert"] = nve;
    }
    return j.dump(1) + "\n";
}

void writeReport(const Analysis& a, const fs::path& dir, const std::string& source) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec || !fs::is_directory(dir)) throw IoError("report folder", dir.string(), "cannot be created");
    const std::string fig6 = fig6Svg(a), fig7 = fig7Svg(a);
    writeFileAtomic(dir / "stats.json", statsJson(a, source));
    writeFileAtomic(dir / "fig6_scores.svg", fig6);
    writeFileAtomic(dir / "fig7_roc.svg", fig7);
    writeFileAtomic(dir / "report.html", reportHtml(a, source, fig6, fig7));
}

namespace {
// RFC 4180: quote a field holding a comma, quote or line break.
std::string csvField(const std::string& v) {
    if (v.find_first_of(",\"\r\n") == std::string::npos) return v;
    std::string q = "\"";
    for (char c : v) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}
}  // namespace

void writeCsv(const StudyData& data, const fs::path& dir) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec || !fs::is_directory(dir)) throw IoError("output folder", dir.string(), "cannot be created");
    std::string r = "observer,group,category,image_id,score\n";
    for (const Rating& x : data.ratings)
        r += fmt::format("{},{},{},{},{}\n", csvField(x.observer), x.group, x.category, csvField(x.imageId), x.score);
    writeFileAtomic(dir / "ratings.csv", r);
    if (data.choices.empty()) return;
    std::string p = "observer,group,left_category,right_category,chosen_category\n";
    for (const Choice& c : data.choices)
        p += fmt::format("{},{},{},{},{}\n", csvField(c.observer), c.group, c.leftCategory, c.rightCategory,
                         c.chosenCategory);
    writeFileAtomic(dir / "pairs.csv", p);
}

}  // namespace mucosa::study
