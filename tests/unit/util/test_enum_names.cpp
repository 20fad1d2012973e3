#include "thermovis/util/enum_names.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>

namespace {

namespace util = thermovis::util;

enum class Colour { red, green, blue, unlisted };

constexpr util::EnumName<Colour> kColourNames[] = {
    {Colour::red, "red"}, {Colour::green, "green"}, {Colour::blue, "blue"}};

TEST(EnumNames, NameOfListedValues) {
  EXPECT_STREQ(util::name_of(kColourNames, Colour::red, "?"), "red");
  EXPECT_STREQ(util::name_of(kColourNames, Colour::blue, "?"), "blue");
  static_assert(std::string_view(util::name_of(kColourNames, Colour::green, "?")) == "green");
}

TEST(EnumNames, NameOfUnlistedValueIsTheFallback) {
  EXPECT_STREQ(util::name_of(kColourNames, Colour::unlisted, "unknown"), "unknown");
  EXPECT_STREQ(util::name_of(kColourNames, static_cast<Colour>(42), "-"), "-");
}

TEST(EnumNames, ParseIsExactAndRoundTrips) {
  for (const auto& entry : kColourNames) {
    EXPECT_EQ(util::parse(kColourNames, util::name_of(kColourNames, entry.value, "?")),
              entry.value);
  }
  EXPECT_FALSE(util::parse(kColourNames, "Red"));
  EXPECT_FALSE(util::parse(kColourNames, "re"));
  EXPECT_FALSE(util::parse(kColourNames, ""));
  static_assert(util::parse(kColourNames, "blue") == Colour::blue);
}

TEST(EnumNames, IntegerCodes) {
  constexpr util::EnumName<std::uint32_t> kCodes[] = {{1, "one"}, {2, "two"}};
  EXPECT_STREQ(util::name_of(kCodes, 2, "-"), "two");
  EXPECT_STREQ(util::name_of(kCodes, 3, "-"), "-");
  EXPECT_EQ(util::parse(kCodes, "one"), 1u);
}

TEST(EnumNames, JoinNames) {
  EXPECT_EQ(util::join_names(kColourNames, ", ", " or "), "red, green or blue");
  EXPECT_EQ(util::join_names(kColourNames, ", ", ", "), "red, green, blue");
  constexpr util::EnumName<int> kOne[] = {{1, "one"}};
  EXPECT_EQ(util::join_names(kOne, ", ", " or "), "one");
  constexpr util::EnumName<int> kTwo[] = {{1, "one"}, {2, "two"}};
  EXPECT_EQ(util::join_names(kTwo, ", ", " or "), "one or two");
}

}  // namespace
