// Command-line mistakes as one line each: an unknown option names the command
// and the nearest option it has, not CLI11's reversed list of leftovers.
#include <algorithm>
#include <cctype>
#include <vector>

#include <fmt/format.h>

#include "commands.hpp"

namespace mucosa::cli {

namespace {

// The deepest subcommand the parse reached.
const CLI::App* deepest(const CLI::App& app) {
    const CLI::App* cur = &app;
    while (!cur->get_subcommands().empty()) cur = cur->get_subcommands().front();
    return cur;
}

bool looksLikeOption(const std::string& arg) {
    // "-5" and "-.5" are values (negative numbers), not options.
    return arg.size() > 1 && arg[0] == '-' && !std::isdigit(static_cast<unsigned char>(arg[1])) && arg[1] != '.';
}

// Every option `cmd` accepts: its own and, since subcommands fall through to
// their parents, its parents'.
std::vector<std::string> optionNames(const CLI::App* cmd) {
    std::vector<std::string> names;
    for (const CLI::App* a = cmd; a != nullptr; a = a->get_parent())
        for (const CLI::Option* o : a->get_options()) {
            for (const std::string& l : o->get_lnames()) names.push_back("--" + l);
            for (const std::string& s : o->get_snames()) names.push_back("-" + s);
        }
    return names;
}

std::string quotedAlternatives(const std::vector<std::string>& words) {
    std::string s;
    for (std::size_t i = 0; i < words.size(); ++i)
        s += fmt::format("{}'{}'", i == 0 ? "" : i + 1 == words.size() ? " or " : ", ", words[i]);
    return s;
}

std::string unknownOption(const CLI::App* cmd, const std::string& path, const std::string& arg) {
    const std::string name = arg.substr(0, arg.find('='));  // "--frequncy=3" -> "--frequncy"
    const auto stripDashes = [](const std::string& s) { return s.substr(s.find_first_not_of('-')); };
    const std::string word = name.find_first_not_of('-') == std::string::npos ? name : stripDashes(name);
    // A one-letter option is one edit from every other: no guess for those.
    std::vector<std::string> candidates, bare;
    if (word.size() > 1)
        for (const std::string& n : optionNames(cmd))
            if (n.size() > 2 && n.rfind("--", 0) == 0) {
                candidates.push_back(n);
                bare.push_back(stripDashes(n));
            }
    std::vector<std::string> close;
    for (const std::string& b : nearest(word, bare))
        close.push_back(candidates[static_cast<std::size_t>(std::find(bare.begin(), bare.end(), b) - bare.begin())]);
    if (close.empty()) return fmt::format("unknown option '{}' in {} (see {} --help)", name, path, path);
    return fmt::format("unknown option '{}' in {}: did you mean {}?", name, path, quotedAlternatives(close));
}

}  // namespace

std::size_t editDistance(std::string_view a, std::string_view b) {
    // Optimal string alignment: Levenshtein's insert, delete and substitute
    // plus Damerau's swap of two adjacent letters ("mdoe" is one edit from "mode").
    const std::size_t n = a.size(), m = b.size();
    std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
    for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
    for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
    for (std::size_t i = 1; i <= n; ++i)
        for (std::size_t j = 1; j <= m; ++j) {
            const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
            d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
                d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
        }
    return d[n][m];
}

std::vector<std::string> nearest(std::string_view word, const std::vector<std::string>& candidates) {
    const std::size_t limit = std::max<std::size_t>(1, word.size() / 3);
    std::size_t best = limit;
    std::vector<std::string> out;
    for (const std::string& c : candidates) {
        const std::size_t d = editDistance(word, c);
        if (d > limit || d > best || std::find(out.begin(), out.end(), c) != out.end()) continue;
        if (d < best) out.clear();
        best = d;
        out.push_back(c);
    }
    return out;
}

std::string commandPath(const CLI::App& app) {
    std::string path = app.get_name();
    for (const CLI::App* cur = &app; !cur->get_subcommands().empty();) {
        cur = cur->get_subcommands().front();
        path += " " + cur->get_name();
    }
    return path;
}

std::string describeParseError(const CLI::App& app, const CLI::ParseError& e) {
    const CLI::App* cmd = deepest(app);
    const std::string path = commandPath(app);
    // Anything left over explains the error best, whatever CLI11 tripped on
    // first (a mistyped --output also makes "--output is required").
    const std::vector<std::string> extras = app.remaining(true);
    if (cmd == &app && !extras.empty() && !looksLikeOption(extras.front())) {
        std::vector<std::string> names;
        for (const CLI::App* s : app.get_subcommands([](const CLI::App*) { return true; }))
            names.push_back(s->get_name());
        const std::vector<std::string> close = nearest(extras.front(), names);
        if (!close.empty())
            return fmt::format("unknown command '{}': did you mean {}?", extras.front(), quotedAlternatives(close));
        return fmt::format("unknown command '{}' (see {} --help)", extras.front(), path);
    }
    for (const std::string& arg : extras)
        if (looksLikeOption(arg)) return unknownOption(cmd, path, arg);
    if (!extras.empty())
        return fmt::format("unexpected argument '{}' in {} (see {} --help)", extras.front(), path, path);
    // "--threads: must be ..." is about an option of the tool, not of the
    // subcommand: point to the help that lists it.
    std::string help = path;
    const std::string what = e.what();
    const std::string option = what.substr(0, what.find(':'));
    if (option.rfind("-", 0) == 0 && cmd->get_option_no_throw(option) == nullptr)
        for (const CLI::App* a = cmd->get_parent(); a != nullptr; a = a->get_parent())
            if (a->get_option_no_throw(option) != nullptr) {
                help = a->get_name();
                for (const CLI::App* p = a->get_parent(); p != nullptr; p = p->get_parent())
                    help = p->get_name() + " " + help;
                break;
            }
    return fmt::format("{} (see {} --help)", what, help);
}

}  // namespace mucosa::cli
