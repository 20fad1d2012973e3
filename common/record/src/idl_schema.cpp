#include "thermovis/record/idl_schema.hpp"

#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace thermovis::record {

namespace {

void flatten(const std::string& file, const std::function<std::string(const std::string&)>& load,
             std::set<std::string>& done, std::vector<std::string>& open, std::string& out) {
  for (const std::string& o : open) {
    if (o == file) throw std::runtime_error("IDL include cycle through " + file);
  }
  if (!done.insert(file).second) return;
  open.push_back(file);
  std::istringstream lines(load(file));
  for (std::string line; std::getline(lines, line);) {
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] != '#') {
      out += line;
      out += '\n';
      continue;
    }
    const auto directive = line.find_first_not_of(" \t", first + 1);
    if (line.compare(directive == std::string::npos ? line.size() : directive, 7, "include") != 0)
      continue;  // #ifndef / #define / #endif: guards a flattened text does not need
    const auto open_quote = line.find_first_of("\"<", directive + 7);
    const auto close_quote =
        open_quote == std::string::npos ? open_quote : line.find_first_of("\">", open_quote + 1);
    if (close_quote == std::string::npos)
      throw std::runtime_error(file + ": malformed #include line: " + line);
    flatten(line.substr(open_quote + 1, close_quote - open_quote - 1), load, done, open, out);
  }
  open.pop_back();
}

}  // namespace

std::string flatten_idl(const std::string& file,
                        const std::function<std::string(const std::string&)>& load) {
  std::set<std::string> done;
  std::vector<std::string> open;
  std::string out;
  flatten(file, load, done, open, out);
  return out;
}

}  // namespace thermovis::record
