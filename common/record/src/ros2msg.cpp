#include "thermovis/record/ros2msg.hpp"

#include <set>
#include <sstream>
#include <stdexcept>

namespace thermovis::record {

namespace {

bool is_primitive(const std::string& type) {
  static const std::set<std::string> primitives{"bool",   "byte",  "char",   "float32", "float64",
                                                "int8",   "uint8", "int16",  "uint16",  "int32",
                                                "uint32", "int64", "uint64", "string",  "wstring"};
  // Bounded strings: "string<=10".
  const std::string base = type.substr(0, type.find("<="));
  return primitives.count(base) > 0;
}

// "pkg/msg/Type" -> "pkg"; throws for another form.
std::string package_of(const std::string& type) {
  const auto first = type.find('/');
  if (first == std::string::npos || first == 0 || type.compare(first, 5, "/msg/") != 0 ||
      type.size() == first + 5 || type.find('/', first + 5) != std::string::npos)
    throw std::runtime_error("ROS 2 message type '" + type + "' is not <package>/msg/<Type>");
  return type.substr(0, first);
}

// A field's type as a .msg file names it ("pkg/Type" or "pkg/msg/Type") -> "pkg/msg/Type".
std::string full_name(const std::string& type) {
  const auto slash = type.find('/');
  if (slash == std::string::npos || type.find('/', slash + 1) != std::string::npos) return type;
  return type.substr(0, slash) + "/msg/" + type.substr(slash + 1);
}

}  // namespace

std::vector<std::string> ros2msg_dependencies(const std::string& package, const std::string& msg) {
  std::set<std::string> types;
  std::istringstream lines(msg);
  int number = 0;
  for (std::string line; std::getline(lines, line);) {
    ++number;
    line = line.substr(0, line.find('#'));
    std::istringstream words(line);
    std::string type, name;
    if (!(words >> type)) continue;  // blank or comment only
    if (!(words >> name))
      throw std::runtime_error("ROS 2 message of package " + package + ", line " +
                               std::to_string(number) + ": '" + line + "' is not '<type> <name>'");
    type = type.substr(0, type.find('['));
    if (is_primitive(type)) continue;  // also every constant: their types are primitive
    if (type == "Header") {
      types.insert("std_msgs/Header");
    } else {
      types.insert(type.find('/') == std::string::npos ? package + "/" + type : type);
    }
  }
  return {types.begin(), types.end()};
}

std::string ros2msg_schema(const std::string& type,
                           const std::function<std::string(const std::string&)>& load) {
  std::set<std::string> seen{type};
  std::function<std::string(const std::string&)> append = [&](const std::string& t) {
    std::string text = load(t);
    for (const std::string& dependency : ros2msg_dependencies(package_of(t), text)) {
      // Once per name as written, as rosbag2 does: readers look a field's type up by that name.
      if (!seen.insert(dependency).second) continue;
      const std::string dependency_type = full_name(dependency);
      package_of(dependency_type);  // a malformed reference is named before it is loaded
      text += "\n" + std::string(kRos2msgSeparator) + "\nMSG: " + dependency + "\n";
      text += append(dependency_type);
    }
    return text;
  };
  package_of(type);
  return append(type);
}

}  // namespace thermovis::record
