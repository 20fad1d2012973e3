#pragma once
// Percentiles of measured values (latencies, CPU times, errors) as the benches, the supervisor
// and the viewer report them.
#include <vector>

namespace thermovis::metrics {

// The p-th percentile (p in 0..100) by nearest rank: the smallest value that at least p % of
// `values` do not exceed (p = 0 gives the minimum, 100 the maximum); always one of the values.
// 0 for an empty list.
double percentile(std::vector<double> values, double p);

}  // namespace thermovis::metrics
