#include <gtest/gtest.h>

#include <map>
#include <stdexcept>

#include "thermovis/record/idl_schema.hpp"

namespace {

using thermovis::record::flatten_idl;
using thermovis::record::fold_constant_expressions;

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

TEST(FoldConstantExpressions, WritesConstantsAndBoundsAsLiterals) {
  const std::string idl =
      "module m {\n"
      "  const unsigned long W = 1920;  // px, W * 2 stays a comment\n"
      "  const unsigned long H = 0x10;\n"
      "  const unsigned long BYTES = W * (H + 2) * 3;\n"
      "  const long long NEG = -(W - 1920) - 5 % 3;\n"
      "  struct S { octet a[1920 * 18 * 3];  // BYTES\n"
      "    unsigned short b[8]; sequence<long, 64> c; octet d[2][H / 4]; };\n"
      "};\n";
  EXPECT_EQ(fold_constant_expressions(idl),
            "module m {\n"
            "  const unsigned long W = 1920;  // px, W * 2 stays a comment\n"
            "  const unsigned long H = 16;\n"
            "  const unsigned long BYTES = 103680;\n"
            "  const long long NEG = -2;\n"
            "  struct S { octet a[103680];  // BYTES\n"
            "    unsigned short b[8]; sequence<long, 64> c; octet d[2][4]; };\n"
            "};\n");
}

TEST(FoldConstantExpressions, AnUnknownNameIsNamed) {
  try {
    fold_constant_expressions("const unsigned long A = B * 2;\n");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'B * 2': 'B' is no integer constant"), std::string::npos)
        << e.what();
  }
}

}  // namespace
