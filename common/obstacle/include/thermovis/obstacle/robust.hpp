#pragma once
// Robust statistics of the stixels and obstacles (obstacles.hpp): the median and the median of
// the absolute deviations from it, as the detector takes them.
#include <utility>
#include <vector>

namespace thermovis::obstacle {

// The median (the upper one of an even count); NaN when v is empty. Reorders v.
double median_of(std::vector<double>& v);

// The median of v as median_of gives it, and the median (the same) of |v - that median|, both
// exactly the values two median_of calls give; NaN for both when v is empty. Sorts v.
std::pair<double, double> median_and_deviation(std::vector<double>& v);

}  // namespace thermovis::obstacle
