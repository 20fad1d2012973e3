#include <gtest/gtest.h>

#include <map>
#include <stdexcept>

#include "thermovis/record/ros2msg.hpp"

namespace {

using thermovis::record::kRos2msgSeparator;
using thermovis::record::ros2msg_dependencies;
using thermovis::record::ros2msg_schema;

TEST(Ros2msgDependencies, FieldTypesInNameOrderWithoutPrimitivesConstantsOrArrays) {
  const std::string msg =
      "# a comment\n"
      "uint8 BAND_VISIBLE = 1\n"
      "\n"
      "Header header  # std_msgs\n"
      "Target[] targets\n"
      "geometry_msgs/Point[<=4] corners\n"
      "builtin_interfaces/msg/Time stamp\n"
      "string<=8 label\n"
      "float32[9] k\n"
      "Target best\n";
  EXPECT_EQ(ros2msg_dependencies("my_msgs", msg),
            (std::vector<std::string>{"builtin_interfaces/msg/Time", "geometry_msgs/Point",
                                      "my_msgs/Target", "std_msgs/Header"}));
}

TEST(Ros2msgDependencies, ALineWithoutANameIsNamed) {
  try {
    ros2msg_dependencies("my_msgs", "uint32 id\nTarget\n");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("my_msgs, line 2"), std::string::npos) << e.what();
  }
}

TEST(Ros2msgSchema, DependenciesDepthFirstOncePerWrittenNameAfterTheirSeparator) {
  const std::map<std::string, std::string> files{
      {"a/msg/Top", "std_msgs/Header header\nB[] bs\nC c\n"},
      {"a/msg/B", "a/msg/C c\n"},
      {"a/msg/C", "float32 x\n"},
      {"std_msgs/msg/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"},
      {"builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec\n"}};
  const std::string sep = std::string("\n") + kRos2msgSeparator + "\nMSG: ";
  EXPECT_EQ(ros2msg_schema("a/msg/Top", [&](const std::string& t) { return files.at(t); }),
            "std_msgs/Header header\nB[] bs\nC c\n" + sep + "a/B\na/msg/C c\n" + sep +
                "a/msg/C\nfloat32 x\n" + sep + "a/C\nfloat32 x\n" + sep +
                "std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n" + sep +
                "builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n");
  EXPECT_EQ(std::string(kRos2msgSeparator).size(), 80U);
}

TEST(Ros2msgSchema, ATypeNameNotPackageMsgTypeIsNamed) {
  for (const char* bad : {"Image", "sensor_msgs/Image", "sensor_msgs/msg/", "/msg/Image"}) {
    try {
      ros2msg_schema(bad, [](const std::string&) { return std::string("int32 x\n"); });
      ADD_FAILURE() << bad << ": no error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
