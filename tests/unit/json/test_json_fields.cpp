// Fields of JSON inputs: the value when it is there and of its type, and otherwise an error
// naming the entry, the field and what it holds; and `thermovis range` with a malformed boxes
// file, as a user meets it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "thermovis/json/fields.hpp"
#include "thermovis/test/data.hpp"

namespace {

namespace tj = thermovis::json;
using nlohmann::json;

// The message of the JsonInputError `f` throws ("" when it throws none).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const tj::JsonInputError& e) {
    return e.what();
  }
  return "";
}

TEST(JsonFields, ReadsFieldsOfTheirType) {
  const json entry = json::parse(R"({"id": "a", "n": 7, "x": -2.5, "on": true, "big": -3})");
  EXPECT_EQ(tj::field<std::string>(entry, "id", "f.json entry 0"), "a");
  EXPECT_EQ(tj::field<std::uint32_t>(entry, "n", "f.json entry 0"), 7U);
  EXPECT_EQ(tj::field<int>(entry, "big", "f.json entry 0"), -3);
  EXPECT_FLOAT_EQ(tj::field<float>(entry, "n", "f.json entry 0"), 7.0F);
  EXPECT_DOUBLE_EQ(tj::field<double>(entry, "x", "f.json entry 0"), -2.5);
  EXPECT_TRUE(tj::field<bool>(entry, "on", "f.json entry 0"));
  EXPECT_EQ(tj::field_or<std::string>(entry, "label", "f.json entry 0", "person"), "person");
  EXPECT_EQ(tj::field_or<std::string>(json::parse(R"({"label": null})"), "label", "w", "p"), "p");
}

TEST(JsonFields, ErrorsNameTheEntryTheFieldAndTheValue) {
  const json entry = json::parse(R"({"id": 7, "n": -1, "s": "x", "f": 1.5, "huge": 70000})");
  EXPECT_EQ(error_of([&] { tj::field<std::string>(entry, "id", "b.json target 2"); }),
            "b.json target 2: field 'id' must be a string, got number 7");
  EXPECT_EQ(error_of([&] { tj::field_or<std::string>(entry, "id", "b.json target 2", "x"); }),
            "b.json target 2: field 'id' must be a string, got number 7");
  EXPECT_EQ(error_of([&] { tj::field<std::uint32_t>(entry, "n", "w"); }),
            "w: field 'n' must be a non-negative integer, got number -1");
  EXPECT_EQ(error_of([&] { tj::field<std::uint32_t>(entry, "f", "w"); }),
            "w: field 'f' must be a non-negative integer, got number 1.5");
  EXPECT_EQ(error_of([&] { tj::field<std::uint16_t>(entry, "huge", "w"); }),
            "w: field 'huge' must be a non-negative integer, got number 70000");
  EXPECT_EQ(error_of([&] { tj::field<double>(entry, "s", "w"); }),
            "w: field 's' must be a number, got string \"x\"");
  EXPECT_EQ(error_of([&] { tj::field<double>(entry, "missing", "w"); }),
            "w: field 'missing' missing");
  EXPECT_EQ(error_of([&] { tj::field<double>(json::array(), "x", "w line 3"); }),
            "w line 3: must be an object, got array []");
}

TEST(JsonFields, RangeNamesTheBoxesFileEntryAndField) {
  const auto dir = thermovis::test::temp_dir("json_fields_range");
  const auto render =
      thermovis::test::run_thermovis("scene render --scene paper --out " + dir.string());
  ASSERT_EQ(render.exit_code, 0) << render.output;
  const auto boxes = dir / "boxes.json";
  std::ofstream(boxes) << R"({"targets": [{"id": "a", "rectified_box": [1, 2, 30, 40]},
                                           {"id": 12, "rectified_box": [1, 2, 30, 40]}]})";
  const auto r = thermovis::test::run_thermovis("range --images " + (dir / "000000").string() +
                                                " --boxes " + boxes.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find(boxes.string() + " target 1: field 'id' must be a string, got number 12"),
            std::string::npos)
      << r.output;

  std::ofstream(boxes) << R"([{"id": "a", "rectified_box": [1, "2", 30, 40]}])";
  const auto r2 = thermovis::test::run_thermovis("range --images " + (dir / "000000").string() +
                                                 " --boxes " + boxes.string());
  EXPECT_NE(r2.exit_code, 0);
  EXPECT_NE(
      r2.output.find(boxes.string() + " target 0: field 'rectified_box' value 1 must be a number"),
      std::string::npos)
      << r2.output;
}

}  // namespace
