#include "thermovis/process/manifest.hpp"

#include <functional>
#include <set>
#include <stdexcept>

namespace thermovis::process {

std::vector<std::string> start_order(const Manifest& manifest) {
  std::map<std::string, const ServiceSpec*> by_name;
  for (const auto& spec : manifest.services) {
    if (!by_name.emplace(spec.name, &spec).second) {
      throw std::invalid_argument("manifest: service '" + spec.name + "' is defined twice");
    }
  }
  std::vector<std::string> order;
  std::set<std::string> done, visiting;
  std::function<void(const ServiceSpec&)> visit = [&](const ServiceSpec& spec) {
    if (done.count(spec.name)) return;
    if (!visiting.insert(spec.name).second) {
      throw std::invalid_argument("manifest: dependency cycle through '" + spec.name + "'");
    }
    for (const auto& dep : spec.depends_on) {
      const auto it = by_name.find(dep);
      if (it == by_name.end()) {
        throw std::invalid_argument("manifest: service '" + spec.name +
                                    "' depends on unknown service '" + dep + "'");
      }
      visit(*it->second);
    }
    visiting.erase(spec.name);
    done.insert(spec.name);
    order.push_back(spec.name);
  };
  for (const auto& spec : manifest.services) visit(spec);
  return order;
}

std::string substitute(const std::string& text, const std::map<std::string, std::string>& vars) {
  std::string out;
  size_t pos = 0;
  while (pos < text.size()) {
    const size_t open = text.find("${", pos);
    if (open == std::string::npos) break;
    const size_t close = text.find('}', open + 2);
    if (close == std::string::npos) break;
    out += text.substr(pos, open - pos);
    const auto it = vars.find(text.substr(open + 2, close - open - 2));
    out += it != vars.end() ? it->second : text.substr(open, close - open + 1);
    pos = close + 1;
  }
  return out + text.substr(pos);
}

const char* to_string(RestartPolicy policy) {
  return util::name_of(kRestartPolicyNames, policy, "?");
}

}  // namespace thermovis::process
