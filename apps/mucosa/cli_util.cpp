#include "commands.hpp"

#include <cstdio>

namespace mucosa::cli {

void info(const Global& g, const std::string& line) {
    if (!g.quiet) std::fprintf(stdout, "%s\n", line.c_str());
}

void warn(const std::string& line) { std::fprintf(stderr, "warning: %s\n", line.c_str()); }

}  // namespace mucosa::cli
