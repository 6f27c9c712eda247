#pragma once
// The mucosa tool: thin subcommands that parse, call the library and report.
// Each cmd_<name>.cpp registers its subcommand(s) with MUCOSA_REGISTER_COMMAND;
// main() adds them to the CLI in `order`.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

namespace mucosa::cli {

// Options shared by the whole tool.
struct Global {
    int threads = 0;  // 0 = all hardware threads
    bool quiet = false;
};

using AddCommand = void (*)(CLI::App& app, Global& global);

struct CommandRegistration {
    CommandRegistration(int order, AddCommand add);
};

// All registered subcommands, sorted by order.
void addRegisteredCommands(CLI::App& app, Global& global);

// Runs a subcommand as if typed after `mucosa` ({"register", "--mesh", ...}),
// with its checks, progress and messages: how `mucosa demo` chains the steps
// a user would run.
void runCommand(Global& global, const std::vector<std::string>& args);

// Messages: stdout for results, stderr for progress, warnings and errors.
void info(const Global& g, const std::string& line);
void warn(const std::string& line);

// "1 frame", "2 frames"; `plural` for nouns that do not take an s ("vertex",
// "vertices").
std::string count(std::uint64_t n, std::string_view singular, std::string_view plural = {});

// "a,b,,c" -> {"a", "b", "c"}: a comma-separated option's items, empty ones dropped.
std::vector<std::string> splitList(const std::string& s);

// A table of per-frame statistics on stdout, tab-separated: a header
// ("frame", then `columns`), one line per frame (name, values to 10 digits),
// then "median" and "iqr" lines (`n` = 0: "nan").
struct StatColumn {
    double median = 0, iqr = 0;
    int n = 0;
};
void printStatsTable(const Global& g, const std::vector<std::string>& columns,
                     const std::vector<std::pair<std::string, std::vector<double>>>& frames,
                     const std::vector<StatColumn>& summary);

// An ETA or elapsed time: "42s", "3m05s", "1h20m".
std::string formatDuration(double seconds);

// A folder path joined with a name for messages: "fit/" and "brdf.json" give
// "fit/brdf.json", not "fit//brdf.json".
std::string joinPath(const std::filesystem::path& dir, std::string_view name);

// An output folder a command will create or fill: an existing directory, or a
// new one whose parent exists and is writable. The folder itself is created,
// its parents are not (as every output file's folder must exist). Throws
// IoError otherwise, before any work.
void requireOutputDir(const std::filesystem::path& dir);

// Validator for a whole-number option in min..max: "must be at least 1, got 0"
// instead of CLI11's range to the largest double.
CLI::Validator wholeNumber(long long min, long long max = std::numeric_limits<int>::max());

// The subcommand path a parse reached ("mucosa study plan"), for messages.
std::string commandPath(const CLI::App& app);

// One line for a parse error, without "error: ": an unknown option names the
// command and suggests the nearest option ("unknown option '--frequncy' in
// mucosa map: did you mean '--frequency'?"); other errors point to the
// command's --help.
std::string describeParseError(const CLI::App& app, const CLI::ParseError& e);

// Optimal string alignment distance (Levenshtein 1966 with adjacent
// transpositions, Damerau 1964): the edits from `a` to `b`.
std::size_t editDistance(std::string_view a, std::string_view b);

// The candidates nearest to `word` if they are close enough to be a typo of it
// (distance at most a third of its length, at least 1), else none.
std::vector<std::string> nearest(std::string_view word, const std::vector<std::string>& candidates);

}  // namespace mucosa::cli

#define MUCOSA_CLI_CONCAT2(a, b) a##b
#define MUCOSA_CLI_CONCAT(a, b) MUCOSA_CLI_CONCAT2(a, b)
// Order of subcommands in --help: map 10, mesh 20, phantom 30, render 40,
// compare 50, view 60, params 65, register 68, fit 70, tune 75, categories 80, study 90, demo 100.
#define MUCOSA_REGISTER_COMMAND(order, fn) \
    static const ::mucosa::cli::CommandRegistration MUCOSA_CLI_CONCAT(kRegistration, __LINE__)(order, fn)
