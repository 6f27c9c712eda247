#pragma once
// The mucosa tool: thin subcommands that parse, call the library and report.
// Each add*Command registers its subcommand and a callback on `app`.
#include <functional>
#include <string>

#include <CLI/CLI.hpp>

namespace mucosa::cli {

// Shared options of the whole tool.
struct Global {
    int threads = 0;  // 0 = all hardware threads
    bool quiet = false;
};

void addMapCommand(CLI::App& app, Global& global);
void addDemoCommand(CLI::App& app, Global& global);

// Messages: stdout for results, stderr for progress, warnings and errors.
void info(const Global& g, const std::string& line);
void warn(const std::string& line);

}  // namespace mucosa::cli
