#include "command.hpp"

#include <algorithm>
#include <exception>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <vector>

#include "thermovis/util/heap.hpp"

namespace thermovis::cli {
namespace {

std::vector<Command>& registry() {
  static std::vector<Command> commands;
  return commands;
}

std::vector<std::string> split_path(const std::string& path) {
  std::vector<std::string> parts;
  std::istringstream in(path);
  for (std::string part; in >> part;) parts.push_back(part);
  return parts;
}

}  // namespace

bool register_command(Command command) {
  registry().push_back(std::move(command));
  return true;
}

int run_main(int argc, char** argv) {
  // The benches measure the stages as the services run them: with the services' heap policy.
  util::keep_freed_heap();
  CLI::App app{"thermovis: wide-angle dual-band (infrared + visible) stereo perception"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "thermovis 0.1.0");

  std::map<std::string, CLI::App*> groups;  // "scene" -> its CLI::App
  std::map<CLI::App*, Runner> runners;
  auto& commands = registry();
  std::sort(commands.begin(), commands.end(),
            [](const Command& a, const Command& b) { return a.path < b.path; });
  for (const Command& command : commands) {
    const auto parts = split_path(command.path);
    CLI::App* parent = &app;
    std::string prefix;
    for (size_t i = 0; i + 1 < parts.size(); ++i) {
      prefix += (prefix.empty() ? "" : " ") + parts[i];
      auto it = groups.find(prefix);
      if (it == groups.end()) {
        CLI::App* group = parent->add_subcommand(parts[i], parts[i] + " commands");
        group->require_subcommand(1);
        it = groups.emplace(prefix, group).first;
      }
      parent = it->second;
    }
    CLI::App* sub = parent->add_subcommand(parts.back(), command.description);
    runners[sub] = command.setup(*sub);
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  // The chosen leaf is the deepest parsed subcommand.
  CLI::App* chosen = &app;
  std::string name = "thermovis";
  for (;;) {
    auto subs = chosen->get_subcommands();
    if (subs.empty()) break;
    chosen = subs.front();
    name += " " + chosen->get_name();
  }
  const auto it = runners.find(chosen);
  if (it == runners.end()) {
    std::cerr << name << ": no such command (see --help)\n";
    return 2;
  }
  try {
    return it->second();
  } catch (const std::exception& e) {
    std::cerr << name << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace thermovis::cli
