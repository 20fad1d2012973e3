#pragma once
// Names of enum values (or of integer codes) from one table: the name of a value, the value of a
// name, and the list of accepted names for an error message, so that the three never disagree.
//
//   constexpr util::EnumName<Band> kBandNames[] = {{Band::infrared, "infrared"}, ...};
//   util::name_of(kBandNames, band, "?");       // "infrared", or "?" for a value not listed
//   util::parse(kBandNames, "visible");         // std::optional<Band>
//   util::join_names(kBandNames, ", ", " or ")  // "infrared, visible or fused"
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>

namespace thermovis::util {

template <typename E>
struct EnumName {
  E value;
  const char* name;
};

// The table's name for `value`, or `fallback` if the table does not list it.
template <typename E, std::size_t N>
constexpr const char* name_of(const EnumName<E> (&table)[N], std::type_identity_t<E> value,
                              const char* fallback) {
  for (const EnumName<E>& entry : table) {
    if (entry.value == value) return entry.name;
  }
  return fallback;
}

// The value the table names `name` (exact match), or nothing.
template <typename E, std::size_t N>
constexpr std::optional<E> parse(const EnumName<E> (&table)[N], std::string_view name) {
  for (const EnumName<E>& entry : table) {
    if (name == entry.name) return entry.value;
  }
  return std::nullopt;
}

// The table's names in order, joined by `separator`, the last two by `last_separator`:
// join_names(t, ", ", " or ") gives "a, b or c"; join_names(t, ", ", ", ") gives "a, b, c".
template <typename E, std::size_t N>
std::string join_names(const EnumName<E> (&table)[N], std::string_view separator,
                       std::string_view last_separator) {
  std::string out;
  for (std::size_t i = 0; i < N; ++i) {
    if (i > 0) out += i + 1 == N ? last_separator : separator;
    out += table[i].name;
  }
  return out;
}

}  // namespace thermovis::util
