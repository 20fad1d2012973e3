#pragma once
// Small helpers for strict YAML config parsing: every error names the source, the line and the key,
// and unknown keys are errors (a misspelt key must not silently fall back to a default).
#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

namespace thermovis::runtime {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Where a node is: "source:line" (1-based line), for messages.
std::string where(const std::string& source, const YAML::Node& node);

// Throws ConfigError unless node is a map whose keys are all in `allowed`.
void check_keys(const std::string& source, const YAML::Node& node, const std::string& context,
                std::initializer_list<const char*> allowed);

// The child `key` of map `node`; throws ConfigError when missing.
YAML::Node require(const std::string& source, const YAML::Node& node, const std::string& context,
                   const std::string& key);

// The key of a map entry (`item.first`); ConfigError unless it is a plain scalar (YAML allows
// lists and maps as keys, which no thermovis file uses).
std::string as_key(const std::string& source, const YAML::Node& key, const std::string& context);

// The elements of a list; ConfigError unless `node` is a sequence (iterating a map or a scalar
// instead would silently read nothing or key/value pairs).
std::vector<YAML::Node> as_list(const std::string& source, const YAML::Node& node,
                                const std::string& context);

// Converts with a clear message on failure ("expected a number", ...).
double as_double(const std::string& source, const YAML::Node& node, const std::string& context);
int as_int(const std::string& source, const YAML::Node& node, const std::string& context);
std::string as_string(const std::string& source, const YAML::Node& node,
                      const std::string& context);
bool as_bool(const std::string& source, const YAML::Node& node, const std::string& context);
// A sequence of numbers, of exactly `size` elements when size >= 0.
std::vector<double> as_doubles(const std::string& source, const YAML::Node& node,
                               const std::string& context, int size = -1);

// Parses text, turning yaml-cpp's syntax errors into ConfigError naming the source and line.
YAML::Node parse_yaml(const std::string& text, const std::string& source);
// The whole text of a file; ConfigError naming the file and `what` it is when missing or
// unreadable.
std::string read_text_file(const std::string& path, const std::string& what);

// Reads a file (ConfigError if missing or unreadable) and parses it.
YAML::Node load_yaml_file(const std::string& path);

}  // namespace thermovis::runtime
