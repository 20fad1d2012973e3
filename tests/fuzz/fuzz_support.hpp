#pragma once
// What every fuzz target accepts from a parser: a result, or the parser's documented error
// whose message names the input (the source name the target passes). Anything else (another
// exception type, an error that does not say where) is reported and aborts, so libFuzzer keeps
// the input as a crash, like a sanitizer report or a hang.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <typeinfo>

namespace thermovis::fuzz {

// The name the targets give their input; every accepted error message must contain it.
inline constexpr const char* kSource = "fuzz-input";

[[noreturn]] inline void fail(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz target failure: %s: %s\n", what, detail.c_str());
  std::abort();
}

// Runs parse(); an exception of type Documented is accepted when its message names kSource,
// any other exception fails.
template <class Documented, class Parse>
bool parses(Parse&& parse) {
  try {
    parse();
    return true;
  } catch (const Documented& e) {
    const std::string what = e.what();
    if (what.find(kSource) == std::string::npos) fail("the error does not name the input", what);
    return false;
  } catch (const std::exception& e) {
    fail(typeid(e).name(), e.what());
  } catch (...) {
    fail("an exception that is not a std::exception", "");
  }
}

}  // namespace thermovis::fuzz
