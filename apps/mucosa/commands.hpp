#pragma once
// The mucosa tool: thin subcommands that parse, call the library and report.
// Each cmd_<name>.cpp registers its subcommand(s) with MUCOSA_REGISTER_COMMAND;
// main() adds them to the CLI in `order`.
#include <functional>
#include <string>

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

// Messages: stdout for results, stderr for progress, warnings and errors.
void info(const Global& g, const std::string& line);
void warn(const std::string& line);

}  // namespace mucosa::cli

#define MUCOSA_CLI_CONCAT2(a, b) a##b
#define MUCOSA_CLI_CONCAT(a, b) MUCOSA_CLI_CONCAT2(a, b)
// Order of subcommands in --help: map 10, mesh 20, phantom 30, render 40,
// compare 50, view 60, fit 70, categories 80, study 90, demo 100.
#define MUCOSA_REGISTER_COMMAND(order, fn) \
    static const ::mucosa::cli::CommandRegistration MUCOSA_CLI_CONCAT(kRegistration, __LINE__)(order, fn)
