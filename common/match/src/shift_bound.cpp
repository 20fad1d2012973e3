#include "thermovis/match/shift_bound.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace thermovis::match {

namespace {

template <class T>
double gradient_energy(const cv::Mat& clean, const cv::Mat& mask) {
  double sum = 0;
  for (int r = 0; r < clean.rows; ++r) {
    const T* p = clean.ptr<T>(r);
    const auto* m = mask.ptr<std::uint8_t>(r);
    for (int c = 1; c + 1 < clean.cols; ++c) {
      if (m[c] == 0) continue;
      const double g = 0.5 * (static_cast<double>(p[c + 1]) - static_cast<double>(p[c - 1]));
      sum += g * g;
    }
  }
  return sum;
}

}  // namespace

double shift_bound_px(const cv::Mat& clean, const cv::Mat& mask, double noise_variance_sum) {
  if (mask.type() != CV_8UC1 || mask.size() != clean.size()) {
    throw std::invalid_argument("shift bound: the mask is not CV_8UC1 of the image's size");
  }
  if (!(noise_variance_sum >= 0) || !std::isfinite(noise_variance_sum)) {
    throw std::invalid_argument("shift bound: the noise variance is not a number >= 0");
  }
  double energy = 0;
  switch (clean.type()) {
    case CV_8UC1:
      energy = gradient_energy<std::uint8_t>(clean, mask);
      break;
    case CV_16UC1:
      energy = gradient_energy<std::uint16_t>(clean, mask);
      break;
    case CV_32FC1:
      energy = gradient_energy<float>(clean, mask);
      break;
    default:
      throw std::invalid_argument("shift bound: the image is not CV_8UC1, CV_16UC1 or CV_32FC1");
  }
  if (!(energy > 0)) return std::numeric_limits<double>::infinity();
  return std::sqrt(noise_variance_sum / energy);
}

}  // namespace thermovis::match
