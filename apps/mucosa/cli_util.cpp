#include "commands.hpp"

#include <algorithm>
#include <cstdio>
#include <utility>
#include <vector>

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

void info(const Global& g, const std::string& line) {
    if (!g.quiet) std::fprintf(stdout, "%s\n", line.c_str());
}

void warn(const std::string& line) {
    std::fprintf(stderr, "warning: %s\n", line.c_str());
}

}  // namespace mucosa::cli
