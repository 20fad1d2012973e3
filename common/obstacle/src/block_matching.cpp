// Block matching (block_matching.hpp): vector kernels compiled once per instruction set Highway
// targets on this architecture (foreach_target.h re-includes this file) and chosen at run time,
// and the row-by-row driver.
//
// Layout: the lanes are a row's pixels (16-bit), not the disparities. Per disparity D the column
// sums C_D(u) = sum over the window's rows of |L(u) - R(u - D)| (u: a column from the first one a
// disparity reaches, disparities - 1) slide down the image one row in and one out; a row's SADs
// are then the sums of block neighbouring C_D, for every D in turn, while each lane keeps its
// best. Every sum is an exact integer under 2^16 (at most 21 x 21 x 62), as StereoBM's 16-bit
// ones are, so the two agree to the bit.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "block_matching.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
// foreach_target.h must come before highway.h.
#include <hwy/highway.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include "thermovis/obstacle/block_matching.hpp"

// Defined once, outside the per-target namespaces (this file is compiled once per target).
#ifndef THERMOVIS_OBSTACLE_BLOCK_MATCHING_ROW_BEST
#define THERMOVIS_OBSTACLE_BLOCK_MATCHING_ROW_BEST
namespace thermovis::obstacle::detail {
// What one row's pixels need of their SADs, per lane.
struct RowBest {
  std::uint16_t* best;     // the least SAD over D
  std::uint16_t* best_d;   // the largest D that has it
  std::uint16_t* before;   // the SAD at best_d - 1 (when best_d > 0)
  std::uint16_t* after;    // the SAD at best_d + 1 (when best_d < disparities - 1)
  std::uint16_t* second;   // the least SAD at a D 2 or more from best_d
  std::uint16_t* texture;  // the window's texture
};
}  // namespace thermovis::obstacle::detail
#endif

HWY_BEFORE_NAMESPACE();
namespace thermovis::obstacle::detail {
namespace HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;

// StereoBM's X-Sobel pre-filter of one row's inner pixels (1 .. cols - 2): clamp(v, -cap, cap) +
// cap, v the x Sobel of rows above, at and below; whole vectors, then pixel by pixel.
void PrefilterRow(const std::uint8_t* above, const std::uint8_t* at, const std::uint8_t* below,
                  int cols, int cap, std::uint8_t* out) {
  const hn::ScalableTag<std::int16_t> d16;
  const hn::Rebind<std::uint8_t, decltype(d16)> d8;
  const auto lanes = static_cast<int>(hn::Lanes(d16));
  const auto load = [&](const std::uint8_t* p) { return hn::PromoteTo(d16, hn::LoadU(d8, p)); };
  const auto low = hn::Set(d16, static_cast<std::int16_t>(-cap));
  const auto high = hn::Set(d16, static_cast<std::int16_t>(cap));
  int x = 1;
  for (; x + lanes <= cols - 1; x += lanes) {
    const auto sobel = hn::Add(hn::Add(hn::Sub(load(above + x + 1), load(above + x - 1)),
                                       hn::Sub(load(below + x + 1), load(below + x - 1))),
                               hn::ShiftLeft<1>(hn::Sub(load(at + x + 1), load(at + x - 1))));
    const auto v = hn::Add(hn::Min(hn::Max(sobel, low), high), high);
    hn::StoreU(hn::DemoteTo(d8, v), d8, out + x);
  }
  for (; x + 1 < cols; ++x) {
    const int v =
        (above[x + 1] - above[x - 1]) + 2 * (at[x + 1] - at[x - 1]) + (below[x + 1] - below[x - 1]);
    out[x] = static_cast<std::uint8_t>(std::clamp(v, -cap, cap) + cap);
  }
}

// C_D(u) += |l(u) - r(u - D)|, and when `out_l` is given -= |out_l(u) - out_r(u - D)|: one row
// entering the columns' window (and one leaving it), for u in whole vectors from 0 until
// `count` is covered; the texture's column sums the same with |l(u) - cap|. `r` may be read up
// to disparities - 1 before itself.
void SlideColumnSums(std::uint16_t* sums, std::ptrdiff_t stride, int disparities, int count,
                     std::uint16_t* texture_sums, int cap, const std::uint8_t* l,
                     const std::uint8_t* r, const std::uint8_t* out_l, const std::uint8_t* out_r) {
  const hn::ScalableTag<std::uint16_t> d16;
  const hn::Rebind<std::uint8_t, decltype(d16)> d8;
  const auto lanes = static_cast<int>(hn::Lanes(d16));
  const auto load = [&](const std::uint8_t* p) { return hn::PromoteTo(d16, hn::LoadU(d8, p)); };
  const auto absdiff = [](auto a, auto b) { return hn::Sub(hn::Max(a, b), hn::Min(a, b)); };
  const auto capv = hn::Set(d16, static_cast<std::uint16_t>(cap));
  for (int u = 0; u < count; u += lanes) {
    const auto in = load(l + u);
    std::uint16_t* c = sums + u;
    auto texture = hn::Add(hn::LoadU(d16, texture_sums + u), absdiff(in, capv));
    if (out_l == nullptr) {
      for (int d = 0; d < disparities; ++d, c += stride) {
        hn::StoreU(hn::Add(hn::LoadU(d16, c), absdiff(in, load(r + u - d))), d16, c);
      }
    } else {
      const auto out = load(out_l + u);
      texture = hn::Sub(texture, absdiff(out, capv));
      for (int d = 0; d < disparities; ++d, c += stride) {
        const auto added = hn::Add(hn::LoadU(d16, c), absdiff(in, load(r + u - d)));
        hn::StoreU(hn::Sub(added, absdiff(out, load(out_r + u - d))), d16, c);
      }
    }
    hn::StoreU(texture, d16, texture_sums + u);
  }
}

// For u in whole vectors from `first` until `end` is covered: each D's SAD, the sum of the column
// sums C_D(u - half .. u + half), taken in turn (D rising); RowBest's values kept on the way.
void BestDisparities(const std::uint16_t* sums, std::ptrdiff_t stride, int disparities, int half,
                     int first, int end, const std::uint16_t* texture_sums, const RowBest& out) {
  const hn::ScalableTag<std::uint16_t> d16;
  const auto lanes = static_cast<int>(hn::Lanes(d16));
  const auto none = hn::Set(d16, 0xffff);
  const auto one = hn::Set(d16, 1);
  const auto window_sum = [&](const std::uint16_t* c) {
    auto sum = hn::LoadU(d16, c);
    for (int i = 1; i <= 2 * half; ++i) sum = hn::Add(sum, hn::LoadU(d16, c + i));
    return sum;
  };
  for (int u = first; u < end; u += lanes) {
    auto best = none, best_d = hn::Zero(d16), before = hn::Zero(d16), after = hn::Zero(d16);
    // The least SAD of D - 2 and less, of D - 1 and less (prefix minima), the least at 2 or more
    // below the best when it was taken (head) and since 2 above it (tail).
    auto least_to_2_below = none, least_to_1_below = none, head = none, tail = none;
    auto last = none, took_last = hn::Zero(d16);
    const std::uint16_t* c = sums + u - half;
    for (int d = 0; d < disparities; ++d, c += stride) {
      const auto dv = hn::Set(d16, static_cast<std::uint16_t>(d));
      const auto sad = window_sum(c);
      const auto lower = hn::Min(best, sad);
      const auto take = sad == lower;  // ties: the larger D, as StereoBM's smaller index
      after = hn::IfThenElse(hn::MaskFromVec(took_last), sad, after);
      before = hn::IfThenElse(take, last, before);
      const auto far = dv > hn::Add(best_d, one);
      tail = hn::IfThenElse(take, none, hn::IfThenElse(far, hn::Min(tail, sad), tail));
      head = hn::IfThenElse(take, least_to_2_below, head);
      best_d = hn::IfThenElse(take, dv, best_d);
      best = lower;
      took_last = hn::VecFromMask(d16, take);
      last = sad;
      least_to_2_below = least_to_1_below;
      least_to_1_below = hn::Min(least_to_1_below, sad);
    }
    hn::StoreU(best, d16, out.best + u);
    hn::StoreU(best_d, d16, out.best_d + u);
    hn::StoreU(before, d16, out.before + u);
    hn::StoreU(after, d16, out.after + u);
    hn::StoreU(hn::Min(head, tail), d16, out.second + u);
    hn::StoreU(window_sum(texture_sums + u - half), d16, out.texture + u);
  }
}

// Each pixel's disparity (1/16 px) from RowBest, or kBlockMatchNone: StereoBM's texture and
// uniqueness tests and its parabola through the best's neighbours, in 32-bit lanes. The division is
// a float one truncated: its numerator is under 2^24 and exact, and an inexact quotient (at most
// 128) lies at least 1 / denominator >= 2^-16 from an integer, farther than the float's error
// (2^-17).
void FinishRow(const RowBest& in, int first, int end, int disparities, int texture_threshold,
               int uniqueness_ratio, std::int16_t* out) {
  const hn::ScalableTag<std::int32_t> d32;
  const hn::Rebind<std::uint16_t, decltype(d32)> d16;
  const hn::Rebind<std::int16_t, decltype(d32)> dout;
  const hn::Rebind<float, decltype(d32)> df;
  const auto lanes = static_cast<int>(hn::Lanes(d32));
  const auto load = [&](const std::uint16_t* p) { return hn::PromoteTo(d32, hn::LoadU(d16, p)); };
  const auto zero = hn::Zero(d32), one = hn::Set(d32, 1);
  const auto none = hn::Set(d32, kBlockMatchNone);
  const auto threshold = hn::Set(d32, texture_threshold);
  const auto ratio = hn::Set(d32, uniqueness_ratio);
  const auto hundred = hn::Set(d32, 100);
  const auto last_d = hn::Set(d32, disparities - 1);
  for (int u = first; u < end; u += lanes) {
    const auto best = load(in.best + u), d = load(in.best_d + u);
    const auto before = load(in.before + u), after = load(in.after + u);
    auto keep = hn::VecFromMask(d32, load(in.texture + u) > hn::Sub(threshold, one));
    if (uniqueness_ratio > 0) {
      // second <= best + floor(best ratio / 100) fails it, i.e. 100 (second - best) <= best ratio.
      const auto margin = hn::Mul(hn::Sub(load(in.second + u), best), hundred);
      keep = hn::And(keep, hn::VecFromMask(d32, margin > hn::Mul(best, ratio)));
    }
    const auto difference = hn::Sub(before, after);
    const auto curvature =
        hn::Add(hn::Sub(hn::Add(before, after), hn::Add(best, best)), hn::Abs(difference));
    const auto flat = curvature == zero;
    const auto divisor = hn::IfThenElse(flat, one, curvature);
    const auto quotient = hn::IfThenZeroElse(
        flat, hn::ConvertTo(d32, hn::Div(hn::ConvertTo(df, hn::ShiftLeft<8>(difference)),
                                         hn::ConvertTo(df, divisor))));
    const auto interior =
        hn::AndNot(hn::VecFromMask(d32, d == zero), hn::VecFromMask(d32, last_d > d));
    const auto fitted =
        hn::ShiftRight<4>(hn::Add(hn::Add(hn::ShiftLeft<8>(d), quotient), hn::Set(d32, 15)));
    const auto value = hn::IfThenElse(hn::MaskFromVec(interior), fitted, hn::ShiftLeft<4>(d));
    hn::StoreU(hn::DemoteTo(dout, hn::IfThenElse(hn::MaskFromVec(keep), value, none)), dout,
               out + u);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace thermovis::obstacle::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace thermovis::obstacle {

namespace detail {
HWY_EXPORT(PrefilterRow);
HWY_EXPORT(SlideColumnSums);
HWY_EXPORT(BestDisparities);
HWY_EXPORT(FinishRow);
}  // namespace detail

namespace {

// More than the widest vector of 16-bit lanes any target has (AVX-512: 32; HWY_MAX_BYTES here
// is the last target compiled, not the widest): the padding every buffer gets beyond what a row
// uses, so that whole vectors never read or write outside it.
constexpr int kPad = 64 + 8;

struct Scratch {
  std::vector<std::uint8_t> left, right;  // pre-filtered, rows of image_stride
  std::vector<std::uint16_t> sums, texture_sums, row;
  std::vector<std::int16_t> out;
};

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

// StereoBM's X-Sobel pre-filter: rows reflected (101) at the top and bottom, its first and last
// columns cap, and (it filters rows in pairs) an odd height's last row all cap.
void prefilter(const cv::Mat& src, int cap, std::vector<std::uint8_t>& out, int stride) {
  const int rows = src.rows, cols = src.cols;
  out.assign(static_cast<std::size_t>(stride) * rows + kPad, 0);
  for (int y = 0; y < rows; ++y) {
    std::uint8_t* o = out.data() + static_cast<std::size_t>(y) * stride;
    if (rows % 2 == 1 && y == rows - 1) {
      std::fill(o, o + cols, static_cast<std::uint8_t>(cap));
      continue;
    }
    const auto* a = src.ptr<std::uint8_t>(y > 0 ? y - 1 : 1);
    const auto* b = src.ptr<std::uint8_t>(y);
    const auto* c = src.ptr<std::uint8_t>(y + 1 < rows ? y + 1 : y - 1);
    o[0] = o[cols - 1] = static_cast<std::uint8_t>(cap);
    HWY_DYNAMIC_DISPATCH(detail::PrefilterRow)(a, b, c, cols, cap, o);
  }
}

}  // namespace

bool block_match_supported(const cv::Mat& left, const cv::Mat& right, const BlockMatchParams& p) {
  return left.type() == CV_8UC1 && right.type() == CV_8UC1 && left.size() == right.size() &&
         p.disparities > 0 && p.disparities % 16 == 0 && p.block >= 5 && p.block <= 21 &&
         p.block % 2 == 1 && p.block < std::min(left.rows, left.cols) && p.texture_threshold >= 0 &&
         p.uniqueness_ratio >= 0 && p.uniqueness_ratio <= 10000 && p.prefilter_cap >= 1 &&
         p.prefilter_cap <= 31 && left.cols <= 32767 - kPad;
}

void block_match(const cv::Mat& left, const cv::Mat& right, const BlockMatchParams& p,
                 cv::Mat& disparity) {
  if (!block_match_supported(left, right, p)) {
    throw std::invalid_argument(
        "block matching: the images are not CV_8UC1 of one size larger than the block, or the "
        "disparities are not a positive multiple of 16, or the block is not odd in 5..21");
  }
  const int rows = left.rows, cols = left.cols, half = p.block / 2, cap = p.prefilter_cap;
  const int disparities = p.disparities;
  disparity.create(rows, cols, CV_16SC1);
  disparity.setTo(kBlockMatchNone);
  // Column u of the sums is image column first_column + u; the outputs are u in [first, end).
  const int first_column = disparities - 1;
  const int width = cols - first_column, first = half, end = width - half;
  if (end <= first) return;

  Scratch& s = scratch();
  const int image_stride = cols + kPad;
  prefilter(left, cap, s.left, image_stride);
  prefilter(right, cap, s.right, image_stride);
  const auto row_of = [&](const std::vector<std::uint8_t>& image, int y) {
    return image.data() + static_cast<std::ptrdiff_t>(y) * image_stride + first_column;
  };
  const int stride = width + 2 * kPad;
  s.sums.assign(static_cast<std::size_t>(stride) * disparities, 0);
  s.texture_sums.assign(static_cast<std::size_t>(stride), 0);
  s.row.resize(static_cast<std::size_t>(stride) * 6);
  s.out.resize(static_cast<std::size_t>(stride));
  std::uint16_t* row = s.row.data();
  const detail::RowBest best{
      row, row + stride, row + 2 * stride, row + 3 * stride, row + 4 * stride, row + 5 * stride};
  // The first output row's window (rows 0 .. block - 1), then one row in and one out per row.
  for (int y = 0; y < p.block; ++y) {
    HWY_DYNAMIC_DISPATCH(detail::SlideColumnSums)
    (s.sums.data(), stride, disparities, width, s.texture_sums.data(), cap, row_of(s.left, y),
     row_of(s.right, y), nullptr, nullptr);
  }
  for (int y = half; y < rows - half; ++y) {
    if (y > half) {
      HWY_DYNAMIC_DISPATCH(detail::SlideColumnSums)
      (s.sums.data(), stride, disparities, width, s.texture_sums.data(), cap,
       row_of(s.left, y + half), row_of(s.right, y + half), row_of(s.left, y - half - 1),
       row_of(s.right, y - half - 1));
    }
    HWY_DYNAMIC_DISPATCH(detail::BestDisparities)
    (s.sums.data(), stride, disparities, half, first, end, s.texture_sums.data(), best);
    HWY_DYNAMIC_DISPATCH(detail::FinishRow)
    (best, first, end, disparities, p.texture_threshold, p.uniqueness_ratio, s.out.data());
    std::copy(s.out.data() + first, s.out.data() + end,
              disparity.ptr<short>(y) + first_column + first);
  }
}

}  // namespace thermovis::obstacle
#endif  // HWY_ONCE
