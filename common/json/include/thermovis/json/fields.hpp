#pragma once
// Typed fields of JSON inputs. Every error is a JsonInputError whose text names where the entry
// is (the caller's `where`: file and entry, e.g. "boxes.json target 2"), the field and what is
// wrong with it, e.g.
//   boxes.json target 2: field 'id' must be a string, got number 7
// instead of the library's bare "[json.exception.type_error.302] type must be string".
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace thermovis::json {

class JsonInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace detail {

template <class T>
constexpr const char* kind() {
  if constexpr (std::is_same_v<T, std::string>) {
    return "a string";
  } else if constexpr (std::is_same_v<T, bool>) {
    return "true or false";
  } else if constexpr (std::is_floating_point_v<T>) {
    return "a number";
  } else {
    static_assert(std::is_integral_v<T>, "a string, bool, integer or floating-point field");
    return std::is_unsigned_v<T> ? "a non-negative integer" : "an integer";
  }
}

// The value as an error shows it: its type and, when short, itself.
inline std::string shown(const nlohmann::json& value) {
  const std::string text = value.dump();
  return std::string(value.type_name()) + (text.size() <= 40 ? " " + text : "");
}

template <class T>
bool fits(const nlohmann::json& v) {
  if constexpr (std::is_same_v<T, std::string>) {
    return v.is_string();
  } else if constexpr (std::is_same_v<T, bool>) {
    return v.is_boolean();
  } else if constexpr (std::is_floating_point_v<T>) {
    return v.is_number();
  } else if (v.is_number_unsigned()) {
    return v.get<std::uint64_t>() <= static_cast<std::uint64_t>(std::numeric_limits<T>::max());
  } else if (v.is_number_integer()) {  // a negative integer (nlohmann keeps others unsigned)
    if constexpr (std::is_unsigned_v<T>) {
      return false;
    } else {
      return v.get<std::int64_t>() >= static_cast<std::int64_t>(std::numeric_limits<T>::min());
    }
  } else {
    return false;
  }
}

}  // namespace detail

// Throws unless `entry` is a JSON object.
inline void require_object(const nlohmann::json& entry, const std::string& where) {
  if (!entry.is_object())
    throw JsonInputError(where + ": must be an object, got " + detail::shown(entry));
}

// entry[name] as T (std::string, bool, an integer or floating-point type); throws when the field
// is missing or of another type (an integer type also rejects a value out of its range).
template <class T>
T field(const nlohmann::json& entry, const std::string& name, const std::string& where) {
  require_object(entry, where);
  const auto it = entry.find(name);
  if (it == entry.end()) throw JsonInputError(where + ": field '" + name + "' missing");
  if (!detail::fits<T>(*it))
    throw JsonInputError(where + ": field '" + name + "' must be " + detail::kind<T>() + ", got " +
                         detail::shown(*it));
  return it->get<T>();
}

// entry[name] as T, or `fallback` when the field is missing or null; throws for another type.
template <class T>
T field_or(const nlohmann::json& entry, const std::string& name, const std::string& where,
           T fallback) {
  require_object(entry, where);
  const auto it = entry.find(name);
  if (it == entry.end() || it->is_null()) return fallback;
  return field<T>(entry, name, where);
}

}  // namespace thermovis::json
