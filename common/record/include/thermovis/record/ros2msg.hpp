#pragma once
// The schema text of a ROS 2 bag's MCAP channel (schema encoding "ros2msg", as rosbag2's MCAP
// storage writes it): the .msg text of the type, then each type it uses, directly or through
// another, once, each after a line of 80 '=' and a line "MSG: <name>", the name as the fields
// write it ("std_msgs/Header": readers such as Foxglove's match the two exactly). The order is
// rosbag2's: depth first, a message's field types in name order.
#include <functional>
#include <string>
#include <vector>

namespace thermovis::record {

// The line of 80 '=' before each dependency.
inline constexpr const char* kRos2msgSeparator =
    "================================================================================";

// The message types a .msg text's fields use, as written ("std_msgs/Header",
// "builtin_interfaces/msg/Time") in name order, each once: a type without a package is
// "<package>/<Type>", "Header" is "std_msgs/Header", primitive types
// (bool, byte, char, float32/64, [u]int8..64, string, wstring, bounded strings) and constants are
// skipped, array suffixes ("[]", "[4]", "[<=4]") dropped. Throws std::runtime_error naming
// `package` and the line for a field line that does not parse.
std::vector<std::string> ros2msg_dependencies(const std::string& package, const std::string& msg);

// The complete "ros2msg" definition of `type` ("<package>/msg/<Type>"). `load(type)` returns the
// .msg text of a type given as "<package>/msg/<Type>" (for a dependency written "pkg/Type" too);
// its errors pass through. Throws
// std::runtime_error for a type name that is not "<package>/msg/<Type>".
std::string ros2msg_schema(const std::string& type,
                           const std::function<std::string(const std::string&)>& load);

}  // namespace thermovis::record
