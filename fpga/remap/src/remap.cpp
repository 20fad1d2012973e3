#include "thermovis/fpga/remap.hpp"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <opencv2/core/utility.hpp>
#include <stdexcept>
#include <string>

#include "remap_kernel.hpp"

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

// The per-pixel datapath of the FPGA stage: the sample at (x_q5, y_q5) (absolute source
// position, 1/32 px) into dst[0..Channels).
template <typename Sample, int Channels>
void sample_model(const cv::Mat& source, int x_q5, int y_q5, Sample* dst) {
  const int w = source.cols;
  const int h = source.rows;
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

// Calls f.template operator()<Sample, Channels>() for a checked image type.
template <typename F>
void with_pixel_format(int type, F&& f) {
  switch (type) {
    case CV_8UC1:
      f.template operator()<std::uint8_t, 1>();
      break;
    case CV_8UC3:
      f.template operator()<std::uint8_t, 3>();
      break;
    default:  // CV_16UC1, checked before
      f.template operator()<std::uint16_t, 1>();
      break;
  }
}

// Lookup(u, v) -> FixedPointEntry (full or quarter table).
template <typename Lookup>
cv::Mat remap_dispatch(const cv::Mat& source, cv::Size out_size, Lookup lookup) {
  cv::Mat out(out_size, source.type());
  with_pixel_format(source.type(), [&]<typename Sample, int Channels>() {
    for (int v = 0; v < out.rows; ++v) {
      auto* dst = out.ptr<Sample>(v);
      for (int u = 0; u < out.cols; ++u, dst += Channels) {
        const FixedPointEntry e = lookup(u, v);
        if (!e.valid()) {
          for (int c = 0; c < Channels; ++c) dst[c] = 0;
          continue;
        }
        sample_model<Sample, Channels>(source, absolute_q5(e.qx, source.cols),
                                       absolute_q5(e.qy, source.rows), dst);
      }
    }
  });
  return out;
}

template <typename Sample, int Channels>
void remap_interior(const detail::InteriorRun& run) {
  if constexpr (Channels == 3) {
    detail::remap_interior_8uc3(run);
  } else if constexpr (sizeof(Sample) == 1) {
    detail::remap_interior_8uc1(run);
  } else {
    detail::remap_interior_16uc1(run);
  }
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

void to_opencv_maps(const FixedPointMap& map, cv::Mat& positions, cv::Mat& fractions) {
  positions.create(map.size(), CV_16SC2);
  fractions.create(map.size(), CV_16UC1);
  const cv::Size source = map.source_size();
  for (int v = 0; v < map.size().height; ++v) {
    auto* pos = positions.ptr<cv::Vec2s>(v);
    auto* frac = fractions.ptr<std::uint16_t>(v);
    for (int u = 0; u < map.size().width; ++u) {
      const FixedPointEntry e = map.at(u, v);
      const int x_q5 = absolute_q5(e.qx, source.width);
      const int y_q5 = absolute_q5(e.qy, source.height);
      pos[u] = cv::Vec2s(static_cast<short>(x_q5 >> kFractionBits),
                         static_cast<short>(y_q5 >> kFractionBits));
      frac[u] = static_cast<std::uint16_t>((y_q5 & (kSubpixelSteps - 1)) * kSubpixelSteps +
                                           (x_q5 & (kSubpixelSteps - 1)));
    }
  }
}

FastRemapper::FastRemapper(const FixedPointMap& map)
    : size_(map.size()), source_size_(map.source_size()) {
  const int w = source_size_.width;
  const int h = source_size_.height;
  entries_.resize(static_cast<std::size_t>(size_.area()));
  row_runs_.reserve(static_cast<std::size_t>(size_.height) + 1);
  std::size_t i = 0;
  for (int v = 0; v < size_.height; ++v) {
    row_runs_.push_back(static_cast<std::int32_t>(runs_.size()));
    for (int u = 0; u < size_.width; ++u, ++i) {
      const FixedPointEntry e = map.at(u, v);
      RunKind kind = RunKind::zero;
      if (e.valid()) {
        const int x_q5 = absolute_q5(e.qx, w);
        const int y_q5 = absolute_q5(e.qy, h);
        const int x0 = x_q5 >> kFractionBits;
        const int y0 = y_q5 >> kFractionBits;
        const bool any_inside = x0 >= -1 && x0 < w && y0 >= -1 && y0 < h;
        // The 8-bit grey and BGR kernels load 2 bytes beyond the right neighbour: past the
        // source's end on its last row unless x0 + 3 < w.
        const bool interior =
            x0 >= 0 && x0 + 1 < w && y0 >= 0 && y0 + 1 < h && (y0 + 2 < h || x0 + 3 < w);
        kind = interior ? RunKind::interior : any_inside ? RunKind::border : RunKind::zero;
        // Zero entries are never read (and may lie beyond what an entry holds).
        if (kind != RunKind::zero) entries_[i] = detail::pack_entry(x_q5, y_q5);
      }
      if (u > 0 && runs_.back().kind == kind) {
        runs_.back().end = u + 1;
      } else {
        runs_.push_back({u, u + 1, kind});
      }
    }
  }
  row_runs_.push_back(static_cast<std::int32_t>(runs_.size()));
}

void FastRemapper::remap(const cv::Mat& source, cv::Mat& out, int first_row, int last_row) const {
  check_remap_source(source, source_size_);
  if (first_row < 0 || first_row > last_row || last_row >= size_.height) {
    throw std::out_of_range("remap: rows " + std::to_string(first_row) + ".." +
                            std::to_string(last_row) + " are not within the table's rows 0.." +
                            std::to_string(size_.height - 1));
  }
  out.create(size_, source.type());
  // The kernel addresses the source with int32 byte offsets; a view into a huge parent image
  // (never a camera frame) is compacted first.
  cv::Mat compact;
  const bool huge_pitch = static_cast<double>(source.step[0]) * source.rows > INT32_MAX;
  if (huge_pitch) compact = source.clone();
  const cv::Mat& src = huge_pitch ? compact : source;
  const auto step = static_cast<std::int32_t>(src.step[0]);
  const std::uint8_t* source_end = src.ptr(src.rows - 1) + src.cols * src.elemSize();

  with_pixel_format(source.type(), [&]<typename Sample, int Channels>() {
    for (int v = first_row; v <= last_row; ++v) {
      auto* row = out.ptr<Sample>(v);
      const std::size_t row_start = static_cast<std::size_t>(v) * size_.width;
      for (std::int32_t r = row_runs_[v]; r < row_runs_[v + 1]; ++r) {
        const Run& run = runs_[r];
        switch (run.kind) {
          case RunKind::zero:
            std::fill(row + run.begin * Channels, row + run.end * Channels, Sample{0});
            break;
          case RunKind::interior:
            remap_interior<Sample, Channels>({src.data, step, source_end,
                                              entries_.data() + row_start + run.begin,
                                              row + run.begin * Channels, run.end - run.begin});
            break;
          case RunKind::border:
            for (int u = run.begin; u < run.end; ++u) {
              const std::uint32_t entry = entries_[row_start + u];
              sample_model<Sample, Channels>(src, detail::entry_x_q5(entry),
                                             detail::entry_y_q5(entry), row + u * Channels);
            }
            break;
        }
      }
    }
  });
}

void FastRemapper::remap(const cv::Mat& source, cv::Mat& out) const {
  const int stripes = std::min(cv::getNumThreads(), size_.height);
  if (stripes <= 1) {
    remap(source, out, 0, size_.height - 1);
    return;
  }
  // OpenCV's worker threads (cv::setNumThreads; a service's --threads) each take a band of
  // rows, which the row-range remap writes bit-identically to the whole one. The checks and
  // the allocation come first, on this thread.
  check_remap_source(source, source_size_);
  out.create(size_, source.type());
  cv::parallel_for_(
      cv::Range(0, size_.height),
      [&](const cv::Range& rows) { remap(source, out, rows.start, rows.end - 1); }, stripes);
}

cv::Mat FastRemapper::remap(const cv::Mat& source) const {
  cv::Mat out;
  remap(source, out);
  return out;
}

}  // namespace thermovis::fpga
