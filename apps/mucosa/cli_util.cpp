#include "commands.hpp"

#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

namespace mucosa::cli {

namespace {
std::vector<std::pair<int, AddCommand>>& registry() {
    static std::vector<std::pair<int, AddCommand>> r;
    return r;
}
}  // namespace

CommandRegistration::CommandRegistration(int order, AddCommand add) {
    registry().emplace_back(order, add);
}

void addRegisteredCommands(CLI::App& app, Global& global) {
    auto r = registry();
    std::stable_sort(r.begin(), r.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [order, add] : r) add(app, global);
}

void runCommand(Global& global, const std::vector<std::string>& args) {
    CLI::App app{"", "mucosa"};
    app.require_subcommand(1);
    addRegisteredCommands(app, global);
    std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them last first
    app.parse(reversed);
}

void info(const Global& g, const std::string& line) {
    if (!g.quiet) std::fprintf(stdout, "%s\n", line.c_str());
}

void warn(const std::string& line) {
    std::fprintf(stderr, "warning: %s\n", line.c_str());
}

std::string count(std::uint64_t n, std::string_view singular, std::string_view plural) {
    if (n == 1) return fmt::format("1 {}", singular);
    if (plural.empty()) return fmt::format("{} {}s", n, singular);
    return fmt::format("{} {}", n, plural);
}

std::vector<std::string> splitList(const std::string& s) {
    std::vector<std::string> out;
    std::size_t pos = 0;
    while (pos <= s.size() && !s.empty()) {
        const auto comma = s.find(',', pos);
        std::string part = s.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
        if (!part.empty()) out.push_back(part);
        if (comma == std::string::npos) break;
        pos = comma + 1;
    }
    return out;
}

void printStatsTable(const Global& g, const std::vector<std::string>& columns,
                     const std::vector<std::pair<std::string, std::vector<double>>>& frames,
                     const std::vector<StatColumn>& summary) {
    std::string header = "frame";
    for (const std::string& c : columns) header += "\t" + c;
    info(g, header);
    for (const auto& [name, values] : frames) {
        std::string line = name;
        for (double v : values) line += fmt::format("\t{:.10g}", v);
        info(g, line);
    }
    std::string med = "median", iqr = "iqr";
    for (const StatColumn& st : summary) {
        med += "\t" + (st.n ? fmt::format("{:.6g}", st.median) : std::string("nan"));
        iqr += "\t" + (st.n ? fmt::format("{:.6g}", st.iqr) : std::string("nan"));
    }
    info(g, med);
    info(g, iqr);
}

std::string formatDuration(double seconds) {
    const long long t = std::llround(std::max(seconds, 0.0));
    if (t >= 3600) return fmt::format("{}h{:02}m", t / 3600, t / 60 % 60);
    if (t >= 60) return fmt::format("{}m{:02}s", t / 60, t % 60);
    return fmt::format("{}s", t);
}

std::string joinPath(const std::filesystem::path& dir, std::string_view name) {
    return (dir / name).lexically_normal().string();
}

void requireOutputDir(const std::filesystem::path& dir) {
    namespace fs = std::filesystem;
    const fs::path d = dir.has_filename() ? dir : dir.parent_path();  // "fit/" -> "fit"
    std::error_code ec;
    const fs::file_status st = fs::status(d, ec);
    if (fs::exists(st)) {
        if (!fs::is_directory(st)) throw IoError("output folder", d.string(), "exists and is not a directory");
        if (::access(d.c_str(), W_OK | X_OK) != 0) throw IoError("output folder", d.string(), "is not writable");
        return;
    }
    requireWritable(d);  // the parent must exist and be writable, as for any output file
}

CLI::Validator wholeNumber(long long min, long long max) {
    std::string description = fmt::format("{}..{}", min, max);
    if (max == std::numeric_limits<int>::max())
        description = min == 0 ? "NONNEGATIVE" : min == 1 ? "POSITIVE" : fmt::format(">={}", min);
    return CLI::Validator(
        [min, max](std::string& text) -> std::string {
            long long v = 0;
            const char* end = text.data() + text.size();
            const auto r = std::from_chars(text.data(), end, v);
            if (r.ptr != end || (r.ec != std::errc() && r.ec != std::errc::result_out_of_range))
                return fmt::format("'{}' is not a whole number", text);
            const bool negative = !text.empty() && text[0] == '-';
            if (r.ec == std::errc::result_out_of_range ? negative : v < min)
                return fmt::format("must be at least {}, got {}", min, text);
            if (r.ec == std::errc::result_out_of_range || v > max)
                return fmt::format("must be at most {}, got {}", max, text);
            return {};
        },
        description);
}

}  // namespace mucosa::cli
