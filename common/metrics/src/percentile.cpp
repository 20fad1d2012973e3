#include "thermovis/metrics/percentile.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace thermovis::metrics {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  // 1-based rank ceil(p/100 n), at least 1.
  const auto rank =
      static_cast<std::size_t>(std::ceil(p / 100.0 * static_cast<double>(values.size())));
  const std::size_t k = std::clamp<std::size_t>(rank, 1, values.size()) - 1;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace thermovis::metrics
