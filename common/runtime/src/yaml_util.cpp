#include "thermovis/runtime/yaml_util.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

namespace thermovis::runtime {

std::string where(const std::string& source, const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  if (mark.line < 0) return source;
  return source + ":" + std::to_string(mark.line + 1);
}

void check_keys(const std::string& source, const YAML::Node& node, const std::string& context,
                std::initializer_list<const char*> allowed) {
  if (!node.IsMap()) throw ConfigError(where(source, node) + ": " + context + ": expected a map");
  for (const auto& item : node) {
    const std::string key = as_key(source, item.first, context);
    bool known = false;
    for (const char* name : allowed) known = known || key == name;
    if (!known) {
      std::string list;
      for (const char* name : allowed) list += (list.empty() ? "" : ", ") + std::string(name);
      throw ConfigError(where(source, item.first) + ": " + context + ": unknown key '" + key +
                        "' (allowed: " + list + ")");
    }
  }
}

YAML::Node require(const std::string& source, const YAML::Node& node, const std::string& context,
                   const std::string& key) {
  if (!node.IsMap()) throw ConfigError(where(source, node) + ": " + context + ": expected a map");
  YAML::Node child = node[key];
  if (!child)
    throw ConfigError(where(source, node) + ": " + context + ": missing key '" + key + "'");
  return child;
}

std::string as_key(const std::string& source, const YAML::Node& key, const std::string& context) {
  if (!key.IsScalar())
    throw ConfigError(where(source, key) + ": " + context + ": a key must be a plain name");
  return key.Scalar();
}

std::vector<YAML::Node> as_list(const std::string& source, const YAML::Node& node,
                                const std::string& context) {
  if (!node.IsSequence())
    throw ConfigError(where(source, node) + ": " + context + ": expected a list");
  return std::vector<YAML::Node>(node.begin(), node.end());
}

double as_double(const std::string& source, const YAML::Node& node, const std::string& context) {
  double value = 0.0;
  if (!node.IsScalar() || !YAML::convert<double>::decode(node, value) || !std::isfinite(value)) {
    throw ConfigError(where(source, node) + ": " + context + ": expected a finite number");
  }
  return value;
}

int as_int(const std::string& source, const YAML::Node& node, const std::string& context) {
  int value = 0;
  if (!node.IsScalar() || !YAML::convert<int>::decode(node, value)) {
    throw ConfigError(where(source, node) + ": " + context + ": expected an integer");
  }
  return value;
}

std::string as_string(const std::string& source, const YAML::Node& node,
                      const std::string& context) {
  if (!node.IsScalar())
    throw ConfigError(where(source, node) + ": " + context + ": expected a string");
  return node.Scalar();
}

bool as_bool(const std::string& source, const YAML::Node& node, const std::string& context) {
  bool value = false;
  if (!node.IsScalar() || !YAML::convert<bool>::decode(node, value)) {
    throw ConfigError(where(source, node) + ": " + context + ": expected true or false");
  }
  return value;
}

std::vector<double> as_doubles(const std::string& source, const YAML::Node& node,
                               const std::string& context, int size) {
  if (!node.IsSequence())
    throw ConfigError(where(source, node) + ": " + context + ": expected a list");
  if (size >= 0 && static_cast<int>(node.size()) != size) {
    throw ConfigError(where(source, node) + ": " + context + ": expected " + std::to_string(size) +
                      " numbers, found " + std::to_string(node.size()));
  }
  std::vector<double> values;
  for (const auto& item : node) values.push_back(as_double(source, item, context));
  return values;
}

YAML::Node parse_yaml(const std::string& text, const std::string& source) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(source + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax: " + e.msg);
  }
}

std::string read_text_file(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open " + what + " (missing or unreadable)");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

YAML::Node load_yaml_file(const std::string& path) {
  return parse_yaml(read_text_file(path, "file"), path);
}

}  // namespace thermovis::runtime
