#pragma once
// VIFB's published metric values (data/fusion/vifb/vifb_metrics_average.csv and
// vifb_metrics_per_image.csv, see that folder's SOURCES.md), read for comparison.
#include <filesystem>
#include <map>
#include <string>

#include "thermovis/metrics/vifb_metrics.hpp"

namespace thermovis::metrics {

// method -> per-metric mean over VIFB's 21 pairs. File format: '#' comment lines, then a header
// "method,CE,EN,...", then one row per method. Throws std::runtime_error naming the file and line
// on a missing file, an unknown metric column or a malformed number.
std::map<std::string, MetricValues> load_vifb_averages(const std::filesystem::path& csv);

// (image, method) -> per-metric value. Format: header "image,method,metric_file_name,metric,value".
// Images with a metric missing keep NaN for it.
std::map<std::pair<std::string, std::string>, MetricValues> load_vifb_per_image(
    const std::filesystem::path& csv);

}  // namespace thermovis::metrics
