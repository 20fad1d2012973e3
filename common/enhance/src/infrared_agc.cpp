#include "thermovis/enhance/infrared_agc.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>

namespace thermovis::enhance {
namespace {

template <typename T>
void count(const cv::Mat& raw, std::vector<double>& hist) {
  std::vector<std::uint32_t> h(hist.size(), 0);
  for (int r = 0; r < raw.rows; ++r) {
    const T* p = raw.ptr<T>(r);
    for (int c = 0; c < raw.cols; ++c) ++h[p[c]];
  }
  for (std::size_t i = 0; i < h.size(); ++i) hist[i] = h[i];
}

// The plateau-equalisation mapping of one frame's histogram, 0..255 per count.
std::vector<float> frame_mapping(std::vector<double> hist, const AgcParams& p) {
  const double total = [&] {
    double t = 0;
    for (double h : hist) t += h;
    return t;
  }();
  // Occupied range after dropping the tails.
  const double tail = p.tail_fraction * total;
  std::size_t lo = 0, hi = hist.size() - 1;
  for (double acc = 0; lo < hist.size(); ++lo) {
    acc += hist[lo];
    if (acc > tail) break;
  }
  for (double acc = 0; hi > lo; --hi) {
    acc += hist[hi];
    if (acc > tail) break;
  }
  std::size_t occupied = 0;
  for (std::size_t i = lo; i <= hi; ++i) occupied += hist[i] > 0 ? 1 : 0;
  const double plateau =
      p.plateau_ratio * total / static_cast<double>(std::max<std::size_t>(occupied, 1));
  std::vector<float> lut(hist.size(), 0.0f);
  if (hi == lo) {
    std::fill(lut.begin(), lut.end(), 128.0f);
    return lut;
  }
  double clipped_total = 0;
  for (std::size_t i = lo; i <= hi; ++i) clipped_total += std::min(hist[i], plateau);
  double acc = 0;
  for (std::size_t i = 0; i < hist.size(); ++i) {
    if (i < lo) {
      lut[i] = 0.0f;
    } else if (i > hi) {
      lut[i] = 255.0f;
    } else {
      // Mid-point of the bin's share of the cumulative sum, so equal inputs map to the centre.
      const double h = std::min(hist[i], plateau);
      lut[i] = static_cast<float>(255.0 * (acc + 0.5 * h) / clipped_total);
      acc += h;
    }
  }
  return lut;
}

}  // namespace

InfraredAgc::InfraredAgc(AgcParams params) : params_(params) {
  if (!(params_.plateau_ratio > 0.0) ||
      !(params_.temporal_alpha > 0.0 && params_.temporal_alpha <= 1.0) ||
      !(params_.tail_fraction >= 0.0 && params_.tail_fraction < 0.5)) {
    throw std::invalid_argument(
        "AGC parameters out of range: plateau_ratio > 0, 0 < temporal_alpha <= 1, 0 <= "
        "tail_fraction < 0.5");
  }
}

void InfraredAgc::reset() { lut_.clear(); }

cv::Mat InfraredAgc::process(const cv::Mat& raw) {
  if (raw.empty()) throw std::invalid_argument("infrared AGC: empty frame");
  if (raw.type() != CV_16UC1 && raw.type() != CV_8UC1) {
    throw std::invalid_argument("infrared AGC needs CV_16UC1 counts or CV_8UC1, got " +
                                cv::typeToString(raw.type()));
  }
  const std::size_t bins = raw.depth() == CV_16U ? 65536 : 256;
  std::vector<double> hist(bins, 0.0);
  if (bins == 256)
    count<uchar>(raw, hist);
  else
    count<std::uint16_t>(raw, hist);
  const auto mapping = frame_mapping(std::move(hist), params_);
  if (lut_.size() != bins) {
    lut_ = mapping;
  } else {
    const float a = static_cast<float>(params_.temporal_alpha);
    for (std::size_t i = 0; i < bins; ++i) lut_[i] += a * (mapping[i] - lut_[i]);
  }
  std::vector<uchar> lut8(bins);
  for (std::size_t i = 0; i < bins; ++i) lut8[i] = cv::saturate_cast<uchar>(lut_[i]);
  cv::Mat out(raw.size(), CV_8UC1);
  for (int r = 0; r < raw.rows; ++r) {
    uchar* o = out.ptr<uchar>(r);
    if (bins == 256) {
      const uchar* p = raw.ptr<uchar>(r);
      for (int c = 0; c < raw.cols; ++c) o[c] = lut8[p[c]];
    } else {
      const std::uint16_t* p = raw.ptr<std::uint16_t>(r);
      for (int c = 0; c < raw.cols; ++c) o[c] = lut8[p[c]];
    }
  }
  return out;
}

}  // namespace thermovis::enhance
