#include <gtest/gtest.h>

#include <map>
#include <stdexcept>

#include "thermovis/record/idl_schema.hpp"

namespace {

using thermovis::record::flatten_idl;

TEST(FlattenIdl, InlinesIncludesOnceAndDropsGuards) {
  const std::map<std::string, std::string> files{
      {"a.idl",
       "#ifndef A\n#define A\n#include \"c.idl\"\n#include \"b.idl\"\nstruct A {};\n#endif\n"},
      {"b.idl", "  #include \"c.idl\"\nstruct B { C c; };\n"},
      {"c.idl", "#pragma once\nmodule m { struct C { long x; }; };\n"}};
  const std::string text = flatten_idl("a.idl", [&](const std::string& f) { return files.at(f); });
  EXPECT_EQ(text, "module m { struct C { long x; }; };\nstruct B { C c; };\nstruct A {};\n");
}

TEST(FlattenIdl, ACycleOrABadIncludeIsNamed) {
  const std::map<std::string, std::string> cycle{{"a.idl", "#include \"b.idl\"\n"},
                                                 {"b.idl", "#include \"a.idl\"\n"}};
  try {
    flatten_idl("a.idl", [&](const std::string& f) { return cycle.at(f); });
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cycle through a.idl"), std::string::npos) << e.what();
  }
  const std::map<std::string, std::string> bad{{"a.idl", "#include b.idl\n"}};
  try {
    flatten_idl("a.idl", [&](const std::string& f) { return bad.at(f); });
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("a.idl: malformed #include"), std::string::npos)
        << e.what();
  }
}

}  // namespace
