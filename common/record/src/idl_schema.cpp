#include "thermovis/record/idl_schema.hpp"

#include <cctype>
#include <cstdint>
#include <map>
#include <regex>
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

// Integer constant expressions: literals, constants declared before, + - * / % and brackets.
class ConstantExpression {
 public:
  ConstantExpression(const std::string& text, const std::map<std::string, std::int64_t>& known)
      : text_(text), known_(known) {}
  std::int64_t value() {
    const std::int64_t v = sum();
    skip_space();
    if (at_ != text_.size()) fail("unexpected '" + text_.substr(at_) + "'");
    return v;
  }

 private:
  std::int64_t sum() {
    std::int64_t v = product();
    for (;;) {
      if (take('+')) {
        v += product();
      } else if (take('-')) {
        v -= product();
      } else {
        return v;
      }
    }
  }
  std::int64_t product() {
    std::int64_t v = factor();
    for (;;) {
      if (take('*')) {
        v *= factor();
      } else if (take('/') || take('%')) {
        const char op = text_[at_ - 1];
        const std::int64_t d = factor();
        if (d == 0) fail("division by zero");
        v = op == '/' ? v / d : v % d;
      } else {
        return v;
      }
    }
  }
  std::int64_t factor() {
    if (take('(')) {
      const std::int64_t v = sum();
      if (!take(')')) fail("missing ')'");
      return v;
    }
    if (take('-')) return -factor();
    skip_space();
    const std::size_t start = at_;
    while (at_ < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[at_])) != 0 ||
                                  text_[at_] == '_' || text_[at_] == ':'))
      ++at_;
    const std::string word = text_.substr(start, at_ - start);
    if (word.empty()) fail("a value is missing");
    if (std::isdigit(static_cast<unsigned char>(word[0])) != 0) {
      std::size_t used = 0;
      const std::int64_t v = std::stoll(word, &used, 0);
      if (used != word.size()) fail("'" + word + "' is not an integer");
      return v;
    }
    const auto it =
        known_.find(word.substr(word.rfind(':') == std::string::npos ? 0 : word.rfind(':') + 1));
    if (it == known_.end()) fail("'" + word + "' is no integer constant declared before");
    return it->second;
  }
  void skip_space() {
    while (at_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[at_])) != 0) ++at_;
  }
  bool take(char c) {
    skip_space();
    if (at_ < text_.size() && text_[at_] == c) {
      ++at_;
      return true;
    }
    return false;
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("IDL constant expression '" + text_ + "': " + what);
  }
  const std::string& text_;
  const std::map<std::string, std::int64_t>& known_;
  std::size_t at_ = 0;
};

}  // namespace

std::string fold_constant_expressions(const std::string& idl) {
  // An integer constant's declaration, and an array bound that is an expression.
  static const std::regex constant(
      R"(^(\s*const\s+(?:unsigned\s+)?(?:long\s+long|long|short|octet)\s+)(\w+)(\s*=\s*)([^;]+)(;.*)$)");
  static const std::regex bound(R"(\[([^\]]*[-+*/%()][^\]]*)\])");
  std::map<std::string, std::int64_t> known;
  std::istringstream lines(idl);
  std::string out;
  for (std::string line; std::getline(lines, line);) {
    const auto comment = line.find("//");
    std::string code = line.substr(0, comment);
    const std::string rest = comment == std::string::npos ? "" : line.substr(comment);
    std::smatch m;
    if (std::regex_match(code, m, constant)) {
      const std::int64_t v = ConstantExpression(m[4].str(), known).value();
      known[m[2].str()] = v;
      code = m[1].str() + m[2].str() + m[3].str() + std::to_string(v) + m[5].str();
    } else {
      std::string folded;
      auto begin = code.cbegin();
      for (std::sregex_iterator it(code.begin(), code.end(), bound), end; it != end; ++it) {
        folded.append(begin, code.cbegin() + it->position());
        folded += '[';
        folded += std::to_string(ConstantExpression((*it)[1].str(), known).value());
        folded += ']';
        begin = code.cbegin() + it->position() + it->length();
      }
      folded.append(begin, code.cend());
      code = folded;
    }
    out += code + rest + '\n';
  }
  return out;
}

std::string flatten_idl(const std::string& file,
                        const std::function<std::string(const std::string&)>& load) {
  std::set<std::string> done;
  std::vector<std::string> open;
  std::string out;
  flatten(file, load, done, open, out);
  return out;
}

}  // namespace thermovis::record
