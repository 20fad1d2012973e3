#include "thermovis/metrics/vifb_tables.hpp"

#include <charconv>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace thermovis::metrics {
namespace {

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string field;
  while (std::getline(ss, field, ',')) out.push_back(field);
  return out;
}

[[noreturn]] void fail(const std::filesystem::path& csv, int line, const std::string& what) {
  throw std::runtime_error(csv.string() + ":" + std::to_string(line) + ": " + what);
}

double parse_number(const std::string& text, const std::filesystem::path& csv, int line) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used != text.size()) fail(csv, line, "not a number: '" + text + "'");
    return v;
  } catch (const std::logic_error&) {
    fail(csv, line, "not a number: '" + text + "'");
  }
}

std::ifstream open(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error("cannot read VIFB table " + csv.string());
  return in;
}

MetricValues all_nan() {
  MetricValues v;
  v.value.fill(std::numeric_limits<double>::quiet_NaN());
  return v;
}

}  // namespace

std::map<std::string, MetricValues> load_vifb_averages(const std::filesystem::path& csv) {
  auto in = open(csv);
  std::map<std::string, MetricValues> out;
  std::vector<Metric> columns;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line.front() == '#') continue;
    const auto fields = split_csv(line);
    if (columns.empty()) {
      if (fields.empty() || fields.front() != "method")
        fail(csv, number, "expected a 'method,...' header");
      for (std::size_t i = 1; i < fields.size(); ++i) {
        const auto m = metric_from_name(fields[i]);
        if (!m) fail(csv, number, "unknown metric column '" + fields[i] + "'");
        columns.push_back(*m);
      }
      continue;
    }
    if (fields.size() != columns.size() + 1) fail(csv, number, "wrong number of fields");
    MetricValues v = all_nan();
    for (std::size_t i = 0; i < columns.size(); ++i)
      v[columns[i]] = parse_number(fields[i + 1], csv, number);
    out[fields.front()] = v;
  }
  if (columns.empty()) fail(csv, number, "no header found");
  return out;
}

std::map<std::pair<std::string, std::string>, MetricValues> load_vifb_per_image(
    const std::filesystem::path& csv) {
  auto in = open(csv);
  std::map<std::pair<std::string, std::string>, MetricValues> out;
  std::string line;
  int number = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line.front() == '#') continue;
    const auto fields = split_csv(line);
    if (!header) {
      if (fields.size() != 5 || fields[0] != "image")
        fail(csv, number, "expected header image,method,metric_file_name,metric,value");
      header = true;
      continue;
    }
    if (fields.size() != 5) fail(csv, number, "expected 5 fields");
    const auto m = metric_from_name(fields[3]);
    if (!m) fail(csv, number, "unknown metric '" + fields[3] + "'");
    auto [it, inserted] = out.try_emplace({fields[0], fields[1]}, all_nan());
    it->second[*m] = parse_number(fields[4], csv, number);
  }
  if (!header) fail(csv, number, "no header found");
  return out;
}

}  // namespace thermovis::metrics
