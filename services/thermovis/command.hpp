#pragma once
// The `thermovis` tool is a set of subcommands, one per source file (cmd_*.cpp). Each file
// registers itself with THERMOVIS_COMMAND, so adding a command touches no shared file.
#include <CLI/CLI.hpp>
#include <functional>
#include <string>

namespace thermovis::cli {

// Called after a successful parse; returns the process exit code. Errors are thrown as
// exceptions (std::exception) and reported by main with the command's name.
using Runner = std::function<int()>;

// Adds the command's options to `app` and returns what runs it. The options must bind to
// state owned by the returned runner (capture a shared_ptr to an options struct).
using Setup = std::function<Runner(CLI::App& app)>;

struct Command {
  std::string path;         // space-separated, e.g. "calibrate" or "scene render"
  std::string description;  // one line for --help
  Setup setup;
};

bool register_command(Command command);

// Builds the CLI tree from every registered command, parses argv and runs the chosen one.
int run_main(int argc, char** argv);

}  // namespace thermovis::cli

#define THERMOVIS_CONCAT_INNER(a, b) a##b
#define THERMOVIS_CONCAT(a, b) THERMOVIS_CONCAT_INNER(a, b)
#define THERMOVIS_COMMAND(path, description, setup_fn)                          \
  static const bool THERMOVIS_CONCAT(thermovis_command_registered_, __LINE__) = \
      ::thermovis::cli::register_command({path, description, setup_fn})
