#include "thermovis/process/manifest_io.hpp"

#include <set>

#include "thermovis/runtime/yaml_util.hpp"

namespace thermovis::process {

using runtime::as_double;
using runtime::as_string;
using runtime::check_keys;
using runtime::ConfigError;
using runtime::require;
using runtime::where;

namespace {

// Durations are turned into clock deadlines (integer nanoseconds): a day is far beyond any
// sensible restart delay or grace, and keeps the conversion in range.
constexpr double kMaxSeconds = 86400.0;

double seconds(const std::string& src, const YAML::Node& node, const std::string& context) {
  const double value = as_double(src, node, context);
  if (!(value > 0.0 && value <= kMaxSeconds)) {
    throw ConfigError(where(src, node) + ": " + context + ": " + node.Scalar() +
                      " s is not in (0, 86400] s");
  }
  return value;
}

}  // namespace

Manifest parse_manifest(const std::string& yaml_text, const std::string& src) {
  const YAML::Node root = runtime::parse_yaml(yaml_text, src);
  if (!root || root.IsNull()) throw ConfigError(src + ": empty manifest file");
  if (!root.IsMap()) throw ConfigError(src + ": expected a manifest map");
  check_keys(src, root, "manifest", {"name", "services"});
  Manifest manifest;
  manifest.name = root["name"] ? as_string(src, root["name"], "name") : "pipeline";
  const YAML::Node services = require(src, root, "manifest", "services");
  if (!services.IsSequence() || services.size() == 0) {
    throw ConfigError(where(src, services) + ": services: expected a non-empty list");
  }
  std::set<std::string> names;
  for (const auto& node : services) {
    check_keys(src, node, "service",
               {"name", "command", "env", "restart", "depends_on", "backoff", "stop_timeout_s",
                "nice", "idle", "realtime"});
    ServiceSpec spec;
    spec.name = as_string(src, require(src, node, "service", "name"), "service.name");
    const std::string ctx = "services." + spec.name;
    if (!names.insert(spec.name).second) {
      throw ConfigError(where(src, node) + ": " + ctx + ": defined twice");
    }
    const YAML::Node command = require(src, node, ctx, "command");
    if (!command.IsSequence() || command.size() == 0) {
      throw ConfigError(where(src, command) + ": " + ctx + ".command: expected a non-empty list");
    }
    for (const auto& arg : command) spec.command.push_back(as_string(src, arg, ctx + ".command"));
    if (node["env"]) {
      if (!node["env"].IsMap())
        throw ConfigError(where(src, node["env"]) + ": " + ctx + ".env: expected a map");
      for (const auto& kv : node["env"]) {
        spec.env[runtime::as_key(src, kv.first, ctx + ".env")] =
            as_string(src, kv.second, ctx + ".env");
      }
    }
    if (node["restart"]) {
      const std::string policy = as_string(src, node["restart"], ctx + ".restart");
      const auto restart = util::parse(kRestartPolicyNames, policy);
      if (!restart) {
        throw ConfigError(where(src, node["restart"]) + ": " + ctx + ".restart: '" + policy +
                          "' is not one of " + util::join_names(kRestartPolicyNames, ", ", ", "));
      }
      spec.restart = *restart;
    }
    if (node["depends_on"]) {
      for (const auto& dep : runtime::as_list(src, node["depends_on"], ctx + ".depends_on"))
        spec.depends_on.push_back(as_string(src, dep, ctx + ".depends_on"));
    }
    if (node["backoff"]) {
      const YAML::Node b = node["backoff"];
      check_keys(src, b, ctx + ".backoff", {"initial_s", "max_s", "stable_after_s"});
      if (b["initial_s"])
        spec.backoff_initial_s = seconds(src, b["initial_s"], ctx + ".backoff.initial_s");
      if (b["max_s"]) spec.backoff_max_s = seconds(src, b["max_s"], ctx + ".backoff.max_s");
      if (b["stable_after_s"])
        spec.stable_after_s = seconds(src, b["stable_after_s"], ctx + ".backoff.stable_after_s");
      if (spec.backoff_initial_s <= 0 || spec.backoff_max_s < spec.backoff_initial_s) {
        throw ConfigError(where(src, b) + ": " + ctx + ".backoff: need 0 < initial_s <= max_s");
      }
    }
    if (node["stop_timeout_s"]) {
      spec.stop_timeout_s = seconds(src, node["stop_timeout_s"], ctx + ".stop_timeout_s");
    }
    if (node["nice"]) {
      spec.nice = runtime::as_int(src, node["nice"], ctx + ".nice");
      if (spec.nice < -20 || spec.nice > 19) {
        throw ConfigError(where(src, node["nice"]) + ": " + ctx +
                          ".nice: " + std::to_string(spec.nice) + " is not in [-20, 19]");
      }
    }
    if (node["idle"]) spec.idle = runtime::as_bool(src, node["idle"], ctx + ".idle");
    if (node["realtime"]) {
      spec.realtime = runtime::as_int(src, node["realtime"], ctx + ".realtime");
      if (spec.realtime < 0 || spec.realtime > 99) {
        throw ConfigError(where(src, node["realtime"]) + ": " + ctx + ".realtime: " +
                          std::to_string(spec.realtime) + " is not in [0, 99] (0: not realtime)");
      }
      if (spec.realtime > 0 && (spec.idle || spec.nice != 0)) {
        throw ConfigError(where(src, node["realtime"]) + ": " + ctx +
                          ": realtime excludes idle and nice (one scheduling policy)");
      }
    }
    manifest.services.push_back(std::move(spec));
  }
  try {
    start_order(manifest);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(src + ": " + e.what());
  }
  return manifest;
}

Manifest load_manifest(const std::filesystem::path& path) {
  return parse_manifest(runtime::read_text_file(path.string(), "manifest"), path.string());
}

}  // namespace thermovis::process
