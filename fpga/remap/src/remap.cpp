#include "thermovis/fpga/remap.hpp"

#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace thermovis::fpga {

namespace {

std::string type_name(int type) {
  switch (type) {
    case CV_8UC1:
      return "8-bit grey (CV_8UC1)";
    case CV_8UC3:
      return "8-bit BGR (CV_8UC3)";
    case CV_16UC1:
      return "16-bit grey (CV_16UC1)";
    default:
      return "OpenCV type " + std::to_string(type);
  }
}

// Rounds acc / 1024 (acc >= 0) half to even.
inline int round_half_even_q10(int acc) {
  const int whole = acc >> 10;
  const int rest = acc & 1023;
  return whole + ((rest > 512 || (rest == 512 && (whole & 1) != 0)) ? 1 : 0);
}

// The per-pixel datapath of the FPGA stage; Lookup(u, v) -> FixedPointEntry (full or quarter
// table).
template <typename Sample, int Channels, typename Lookup>
void remap_model(const cv::Mat& source, cv::Mat& out, Lookup lookup) {
  const int w = source.cols;
  const int h = source.rows;
  for (int v = 0; v < out.rows; ++v) {
    auto* dst = out.ptr<Sample>(v);
    for (int u = 0; u < out.cols; ++u, dst += Channels) {
      const FixedPointEntry e = lookup(u, v);
      if (!e.valid()) {
        for (int c = 0; c < Channels; ++c) dst[c] = 0;
        continue;
      }
      const int x_q5 = absolute_q5(e.qx, w);
      const int y_q5 = absolute_q5(e.qy, h);
      const int x0 = x_q5 >> kFractionBits;  // arithmetic shift: floor
      const int y0 = y_q5 >> kFractionBits;
      const int fx = x_q5 & (kSubpixelSteps - 1);
      const int fy = y_q5 & (kSubpixelSteps - 1);
      const int weights[4] = {(32 - fx) * (32 - fy), fx * (32 - fy), (32 - fx) * fy, fx * fy};
      const int xs[4] = {x0, x0 + 1, x0, x0 + 1};
      const int ys[4] = {y0, y0, y0 + 1, y0 + 1};
      for (int c = 0; c < Channels; ++c) {
        int acc = 0;
        for (int k = 0; k < 4; ++k) {
          if (xs[k] < 0 || ys[k] < 0 || xs[k] >= w || ys[k] >= h) continue;  // border = 0
          acc += weights[k] * source.ptr<Sample>(ys[k])[xs[k] * Channels + c];
        }
        if constexpr (sizeof(Sample) == 1) {
          dst[c] = static_cast<Sample>((acc + 512) >> 10);
        } else {
          dst[c] = static_cast<Sample>(round_half_even_q10(acc));
        }
      }
    }
  }
}

template <typename Lookup>
cv::Mat remap_dispatch(const cv::Mat& source, cv::Size out_size, Lookup lookup) {
  cv::Mat out(out_size, source.type());
  switch (source.type()) {
    case CV_8UC1:
      remap_model<std::uint8_t, 1>(source, out, lookup);
      break;
    case CV_8UC3:
      remap_model<std::uint8_t, 3>(source, out, lookup);
      break;
    default:  // CV_16UC1, checked before
      remap_model<std::uint16_t, 1>(source, out, lookup);
      break;
  }
  return out;
}

}  // namespace

void check_remap_source(const cv::Mat& source, cv::Size expected_size) {
  if (source.empty()) throw std::invalid_argument("remap: the input image is empty");
  const int type = source.type();
  if (type != CV_8UC1 && type != CV_8UC3 && type != CV_16UC1) {
    throw std::invalid_argument("remap: unsupported pixel format " + type_name(type) +
                                "; expected 8-bit grey, 8-bit BGR or 16-bit grey");
  }
  if (source.size() != expected_size) {
    throw std::invalid_argument("remap: input image is " + std::to_string(source.cols) + "x" +
                                std::to_string(source.rows) + " but the table was made for a " +
                                std::to_string(expected_size.width) + "x" +
                                std::to_string(expected_size.height) + " camera");
  }
}

cv::Mat remap_reference(const cv::Mat& source, const FixedPointMap& map) {
  check_remap_source(source, map.source_size());
  return remap_dispatch(source, map.size(), [&map](int u, int v) { return map.at(u, v); });
}

cv::Mat remap_reference(const cv::Mat& source, const QuarterTable& table) {
  check_remap_source(source, table.source_size());
  return remap_dispatch(source, table.full_size(),
                        [&table](int u, int v) { return table.at(u, v); });
}

FastRemapper::FastRemapper(const FixedPointMap& map)
    : positions_(map.size(), CV_16SC2),
      fractions_(map.size(), CV_16UC1),
      source_size_(map.source_size()) {
  for (int v = 0; v < map.size().height; ++v) {
    auto* pos = positions_.ptr<cv::Vec2s>(v);
    auto* frac = fractions_.ptr<std::uint16_t>(v);
    for (int u = 0; u < map.size().width; ++u) {
      const FixedPointEntry e = map.at(u, v);
      const int x_q5 = absolute_q5(e.qx, source_size_.width);
      const int y_q5 = absolute_q5(e.qy, source_size_.height);
      // Invalid entries land more than a pixel outside the source (see fixed_map.hpp): 0.
      pos[u] = cv::Vec2s(static_cast<short>(x_q5 >> kFractionBits),
                         static_cast<short>(y_q5 >> kFractionBits));
      frac[u] = static_cast<std::uint16_t>((y_q5 & (kSubpixelSteps - 1)) * kSubpixelSteps +
                                           (x_q5 & (kSubpixelSteps - 1)));
    }
  }
}

void FastRemapper::remap(const cv::Mat& source, cv::Mat& out) const {
  check_remap_source(source, source_size_);
  cv::remap(source, out, positions_, fractions_, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar::all(0));
}

cv::Mat FastRemapper::remap(const cv::Mat& source) const {
  cv::Mat out;
  remap(source, out);
  return out;
}

}  // namespace thermovis::fpga
