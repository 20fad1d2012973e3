// The vector kernel of FastRemapper, compiled once per instruction set Highway targets on this
// architecture (foreach_target.h re-includes this file) and chosen at run time (AVX2 on the
// reference machine, SSE4/SSSE3 or plain C++ elsewhere): bit for bit the datapath of
// remap_reference (remap.hpp), on int32 lanes.
//
// Per lane (one output pixel): the source byte offset of the top-left neighbour is
// y0 * step + x0 * bytes_per_pixel; one word per row (and channel) brings both horizontal
// neighbours (8-bit grey: bytes 0 and 1 of a 32-bit word, 16-bit: its halves, BGR: bytes 0-2
// and 3-5 of a 64-bit word; x86 and every Highway target are little-endian). Grey images are
// interpolated separably,
//   top = 32 p00 + (p01 - p00) fx,  bottom = 32 p10 + (p11 - p10) fx,
//   acc = 32 top + (bottom - top) fy,
// BGR images with int16 multiply-adds of the four weights (bgr_sums_by_pairs); both give the
// same integer as the four-weight sum of the model (1/1024 units), so the rounding rules of
// remap.hpp apply unchanged.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "remap_kernel.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
// foreach_target.h must come before highway.h.
#include <hwy/highway.h>

#include <hwy/cache_control.h>
#include <algorithm>
#include <cstddef>
#include <cstring>

#include "remap_kernel.hpp"
#include "thermovis/fpga/fixed_map.hpp"

HWY_BEFORE_NAMESPACE();
namespace thermovis::fpga::detail {
namespace HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;

// The horizontal neighbours of Lanes(d) pixels on one source row, channel by channel: per
// channel one 32-bit word per pixel (a gather: ~8% faster than lane by lane for the 16-bit
// kernel on the rig's infrared table), holding the left sample in its low bytes and the right
// one kPixelBytes further (any vector size, the tail's single lanes included).
template <typename Sample, int Channels, class D, class V = hn::Vec<D>>
HWY_INLINE void load_pairs_by_word(D d, const std::uint8_t* source, V offsets, V* left, V* right) {
  constexpr int kPixelBytes = static_cast<int>(sizeof(Sample)) * Channels;
  const V sample_mask = hn::Set(d, sizeof(Sample) == 1 ? 0xff : 0xffff);
  for (int c = 0; c < Channels; ++c) {
    const std::uint8_t* channel = source + c * static_cast<int>(sizeof(Sample));
    V word;
    if constexpr (hn::MaxLanes(D()) == hn::MaxLanes(hn::ScalableTag<std::int32_t>())) {
      // GatherOffset takes byte offsets; the words need no alignment.
      word = hn::GatherOffset(d, reinterpret_cast<const std::int32_t*>(channel), offsets);
    } else {
      // Partial vectors (the tail's single lanes): AVX2's 128-bit gather would also read at
      // the unused lanes' offsets, so lane by lane.
      HWY_ALIGN std::int32_t lane_offsets[hn::MaxLanes(D())];
      HWY_ALIGN std::int32_t words[hn::MaxLanes(D())];
      hn::Store(offsets, d, lane_offsets);
      for (std::size_t k = 0; k < hn::Lanes(d); ++k) {
        std::memcpy(&words[k], channel + lane_offsets[k], sizeof(std::int32_t));
      }
      word = hn::Load(d, words);
    }
    left[c] = hn::And(word, sample_mask);
    right[c] = hn::And(hn::ShiftRight<8 * kPixelBytes>(word), sample_mask);
  }
}

#if HWY_TARGET != HWY_SCALAR
// A vector of 64-bit words read at source + offsets[pixel(lane)], by scalar loads combined into
// halves and wholes. On the reference machine (AMD Zen 3, virtualised) a gather instruction
// costs about 16-20 cycles whatever its width: for BGR's pixel pairs in permuted lanes, loading
// lane by lane made the kernel ~1.3x faster than 64-bit gathers.
template <class DW, class PixelOfLane>
HWY_INLINE hn::Vec<DW> load_words(DW dw, const std::uint8_t* source, const std::int32_t* offsets,
                                  PixelOfLane pixel_of_lane, int first_lane = 0) {
  constexpr std::size_t kLanes = hn::MaxLanes(DW());
  if constexpr (kLanes > 1) {
    const hn::Half<DW> dhalf;
    constexpr int kHalf = static_cast<int>(kLanes / 2);
    return hn::Combine(dw, load_words(dhalf, source, offsets, pixel_of_lane, first_lane + kHalf),
                       load_words(dhalf, source, offsets, pixel_of_lane, first_lane));
  } else {
    hn::TFromD<DW> word;
    std::memcpy(&word, source + offsets[pixel_of_lane(first_lane)], sizeof(word));
    return hn::Set(dw, word);
  }
}

// The bilinear sums of BGR pixels with vectors of at least 4 lanes. One 64-bit word brings both
// neighbours of a pixel on a row (bytes B G R B' G' R', 6 of 8): two loads per pixel and row
// instead of three. Vector A takes the even pairs of pixels (0, 1, 4, 5, ...), B the odd pairs
// (2, 3, 6, 7, ...), so that one byte shuffle per 128-bit block and channel puts each pixel's
// (left, right) samples as an int16 pair in its own int32 lane; one multiply-add of int16 pairs
// per row (_mm256_madd_epi16 on x86) then gives
//   acc = (32 - fx)(32 - fy) p00 + fx (32 - fy) p01 + (32 - fx) fy p10 + fx fy p11,
// the model's four-weight sum itself (weights <= 1024, samples <= 255: no overflow).
template <class D, class V = hn::Vec<D>>
HWY_INLINE void bgr_sums_by_pairs(D d, const std::uint8_t* source, const std::int32_t* top,
                                  const std::int32_t* bottom, V fx, V fy, V* acc) {
  const hn::Repartition<std::uint64_t, D> du64;
  const hn::Repartition<std::uint8_t, D> du8;
  const hn::Repartition<std::int16_t, D> di16;
  // u64 lane j of A is pixel 4 (j / 2) + j % 2; of B, two pixels further.
  const auto pixel_of_a = [](int j) { return 4 * (j / 2) + j % 2; };
  const auto pixel_of_b = [](int j) { return 4 * (j / 2) + j % 2 + 2; };
  const auto top_a = hn::BitCast(du8, load_words(du64, source, top, pixel_of_a));
  const auto top_b = hn::BitCast(du8, load_words(du64, source, top, pixel_of_b));
  const auto bottom_a = hn::BitCast(du8, load_words(du64, source, bottom, pixel_of_a));
  const auto bottom_b = hn::BitCast(du8, load_words(du64, source, bottom, pixel_of_b));
  // Weight pairs (left, right) per pixel and row, as int16 in the int32 lanes (little-endian).
  const V wx0 = hn::Sub(hn::Set(d, 32), fx);
  const V wy0 = hn::Sub(hn::Set(d, 32), fy);
  const auto top_weights =
      hn::BitCast(di16, hn::Or(hn::Mul(wx0, wy0), hn::ShiftLeft<16>(hn::Mul(fx, wy0))));
  const auto bottom_weights =
      hn::BitCast(di16, hn::Or(hn::Mul(wx0, fy), hn::ShiftLeft<16>(hn::Mul(fx, fy))));
  for (int c = 0; c < 3; ++c) {
    // Per 128-bit block: A holds pixels 0 and 1 of the block's four (bytes 0-7, 8-15), B pixels
    // 2 and 3; lane k gets bytes (c, 3 + c) of its pixel's word, zero-extended (0x80 gives 0).
    const auto l0 = static_cast<std::uint8_t>(c);
    const auto r0 = static_cast<std::uint8_t>(3 + c);
    const auto l1 = static_cast<std::uint8_t>(8 + c);
    const auto r1 = static_cast<std::uint8_t>(11 + c);
    constexpr std::uint8_t z = 0x80;
    alignas(16)
        const std::uint8_t from_a[16] = {l0, z, r0, z, l1, z, r1, z, z, z, z, z, z, z, z, z};
    alignas(16)
        const std::uint8_t from_b[16] = {z, z, z, z, z, z, z, z, l0, z, r0, z, l1, z, r1, z};
    const auto shuffle_a = hn::LoadDup128(du8, from_a);
    const auto shuffle_b = hn::LoadDup128(du8, from_b);
    const auto pairs = [&](decltype(top_a) a, decltype(top_a) b) {
      return hn::BitCast(di16, hn::Or(hn::TableLookupBytesOr0(a, shuffle_a),
                                      hn::TableLookupBytesOr0(b, shuffle_b)));
    };
    V odd_sums = hn::Zero(d);
    V sums =
        hn::ReorderWidenMulAccumulate(d, pairs(top_a, top_b), top_weights, hn::Zero(d), odd_sums);
    sums =
        hn::ReorderWidenMulAccumulate(d, pairs(bottom_a, bottom_b), bottom_weights, sums, odd_sums);
    acc[c] = hn::RearrangeToOddPlusEven(sums, odd_sums);
  }
}
#endif

// The entries (pack_entry) of pixels i .. i + Lanes(d) - 1 as their absolute positions plus
// one pixel, 1/32 px: x in `x`, y in `y`.
template <class D>
HWY_INLINE void load_entries(D d, const InteriorRun& run, int i, hn::Vec<D>* x, hn::Vec<D>* y) {
  const hn::RebindToUnsigned<D> du;
  const auto entries = hn::LoadU(du, run.entries + i);
  *x = hn::BitCast(d, hn::And(entries, hn::Set(du, 0xffffu)));
  *y = hn::BitCast(d, hn::ShiftRight<16>(entries));  // logical: y + 32 may exceed 2^15
}

// Byte offsets in the source of the top-left neighbours of pixels with positions x, y (as
// load_entries gives them): the entries' added pixel is taken off here.
template <int PixelBytes, class D, class V = hn::Vec<D>>
HWY_INLINE V top_left_offsets(D d, const InteriorRun& run, V x, V y) {
  const V x0 = hn::ShiftRight<kFractionBits>(x);
  const V y0 = hn::ShiftRight<kFractionBits>(y);
  return hn::Sub(hn::Add(hn::Mul(y0, hn::Set(d, run.step)), hn::Mul(x0, hn::Set(d, PixelBytes))),
                 hn::Set(d, run.step + PixelBytes));
}

// Samples Lanes(d) output pixels from pixel `i` of the run.
template <typename Sample, int Channels, class D>
HWY_INLINE void remap_lanes(D d, const InteriorRun& run, int i) {
  using V = hn::Vec<D>;
  constexpr int kPixelBytes = static_cast<int>(sizeof(Sample)) * Channels;

  V x, y;
  load_entries(d, run, i, &x, &y);
  const V fx = hn::And(x, hn::Set(d, kSubpixelSteps - 1));
  const V fy = hn::And(y, hn::Set(d, kSubpixelSteps - 1));
  const V top_offsets = top_left_offsets<kPixelBytes>(d, run, x, y);
  const V bottom_offsets = hn::Add(top_offsets, hn::Set(d, run.step));

  V acc[Channels];
#if HWY_TARGET != HWY_SCALAR
  if constexpr (Channels == 3 && hn::MaxLanes(D()) >= 4) {
    HWY_ALIGN std::int32_t top[hn::MaxLanes(D())];
    HWY_ALIGN std::int32_t bottom[hn::MaxLanes(D())];
    hn::Store(top_offsets, d, top);
    hn::Store(bottom_offsets, d, bottom);
    bgr_sums_by_pairs(d, run.source, top, bottom, fx, fy, acc);
  } else  // NOLINT(readability/braces): the scalar target has the word path only
#endif
  {
    // 32 x the horizontal interpolation of each row (1/32 units), then the vertical one.
    V top_left[Channels], top_right[Channels], bottom_left[Channels], bottom_right[Channels];
    load_pairs_by_word<Sample, Channels>(d, run.source, top_offsets, top_left, top_right);
    load_pairs_by_word<Sample, Channels>(d, run.source, bottom_offsets, bottom_left, bottom_right);
    const auto interpolate = [&](V left, V right) {
      return hn::Add(hn::ShiftLeft<5>(left), hn::Mul(hn::Sub(right, left), fx));
    };
    for (int c = 0; c < Channels; ++c) {
      const V upper = interpolate(top_left[c], top_right[c]);
      const V lower = interpolate(bottom_left[c], bottom_right[c]);
      acc[c] = hn::Add(hn::ShiftLeft<5>(upper), hn::Mul(hn::Sub(lower, upper), fy));
    }
  }
  V result[Channels];
  for (int c = 0; c < Channels; ++c) {
    if constexpr (sizeof(Sample) == 1) {
      result[c] = hn::ShiftRight<10>(hn::Add(acc[c], hn::Set(d, 512)));  // round half up
    } else {
      // Half to even: adding 511 + (the integer part's low bit) carries exactly when the
      // remainder exceeds 512, or equals 512 on an odd integer part.
      const V odd = hn::And(hn::ShiftRight<10>(acc[c]), hn::Set(d, 1));
      result[c] = hn::ShiftRight<10>(hn::Add(hn::Add(acc[c], hn::Set(d, 511)), odd));
    }
  }

  const hn::Rebind<Sample, D> d_out;
  Sample* out = static_cast<Sample*>(run.out) + static_cast<std::ptrdiff_t>(i) * Channels;
  if constexpr (Channels == 1) {
    hn::StoreU(hn::DemoteTo(d_out, result[0]), d_out, out);
  } else {
    static_assert(Channels == 3, "the kernel handles grey and BGR");
    hn::StoreInterleaved3(hn::DemoteTo(d_out, result[0]), hn::DemoteTo(d_out, result[1]),
                          hn::DemoteTo(d_out, result[2]), d_out, out);
  }
}

#if HWY_TARGET != HWY_SCALAR
// The grey kernels without gathers. Each 128-bit block of the vector holds 8 output pixels (8-bit
// samples, as int16 lanes) or 4 (16-bit samples, int32 lanes); for each block, three or four
// 16-byte windows of the source (rows y.. from column x, where x is the block's first pixel's
// left neighbour and y the upper of its first and last pixels' top rows) hold all four
// neighbours of every pixel of the block when its left neighbours lie within the window's
// samples but the last and its top rows within two of y: a byte shuffle per window and
// neighbour column (TableLookupBytesOr0) brings them into the lanes. On the rig's rectified
// tables a grid row crosses source rows slowly (up to about two rows in 8 px near the corners)
// and the source's scale is 0.5-1 px a pixel, so nearly every block fits; a vector with a block
// that does not (a row turning within it, a steep or strongly reduced map, the source's last
// bytes) goes the gather way (remap_lanes).
constexpr int kWindowBytes = 16;
constexpr int kMaxWindowRows = 4;

// A vector of bytes, each 128-bit block loaded from its own window (windows[b] for block b).
template <class D8>
HWY_INLINE hn::Vec<D8> load_windows(D8 d, const std::uint8_t* const* windows) {
  if constexpr (hn::MaxLanes(D8()) > static_cast<std::size_t>(kWindowBytes)) {
    const hn::Half<D8> dh;
    constexpr std::size_t kLowerBlocks = hn::MaxLanes(D8()) / 2 / kWindowBytes;
    return hn::Combine(d, load_windows(dh, windows + kLowerBlocks), load_windows(dh, windows));
  } else {
    return hn::LoadU(d, windows[0]);
  }
}

// The window rows a vector's blocks need (3 or 4), or 0 when a pixel's left neighbour lies
// beyond sample `last_column` of its block's windows or its top row more than two below the
// block's upper: `column` and `row` per pixel, unsigned (left of or above the block's first
// wraps high).
template <class DU, class V = hn::Vec<DU>>
HWY_INLINE int window_rows(DU du, V column, V row, int last_column) {
  using T = hn::TFromD<DU>;
  if (!hn::AllFalse(du, hn::Gt(column, hn::Set(du, static_cast<T>(last_column)))) ||
      !hn::AllFalse(du, hn::Gt(row, hn::Set(du, static_cast<T>(kMaxWindowRows - 2))))) {
    return 0;
  }
  return hn::AllFalse(du, hn::Eq(row, hn::Set(du, T{2}))) ? 3 : 4;
}

// The byte offset in the source of the top-left neighbour of the position whose x is the low
// half of entry `x_of` and whose y is the high half of `y_of` (pack_entry: one pixel added to
// each).
template <int kPixelBytes>
HWY_INLINE std::ptrdiff_t top_left_offset(const InteriorRun& run, std::uint32_t x_of,
                                          std::uint32_t y_of) {
  const std::ptrdiff_t x = static_cast<std::ptrdiff_t>(x_of & 0xffffu) >> kFractionBits;
  const std::ptrdiff_t y = static_cast<std::ptrdiff_t>(y_of >> 16) >> kFractionBits;
  return (y - 1) * run.step + (x - 1) * kPixelBytes;
}

// Each block's `rows` windows (windows[r][b]: row r of block b), its first pixel's entry at
// entries[b * kBlockPixels]; false when the last would end beyond the source. The upper row of
// two entries is that of the smaller (y is in the high half).
template <int kBlockPixels, int kPixelBytes, std::size_t kBlocks>
HWY_INLINE bool block_windows(const InteriorRun& run, const std::uint32_t* entries, int rows,
                              const std::uint8_t* (&windows)[kMaxWindowRows][kBlocks]) {
  const std::ptrdiff_t readable = run.source_end - run.source;
  for (std::size_t b = 0; b < kBlocks; ++b) {
    const std::uint32_t first = entries[b * kBlockPixels];
    const std::uint32_t last = entries[b * kBlockPixels + kBlockPixels - 1];
    const std::ptrdiff_t top = top_left_offset<kPixelBytes>(run, first, std::min(first, last));
    if (top + (rows - 1) * run.step + kWindowBytes > readable) return false;
    for (int r = 0; r < rows; ++r) windows[r][b] = run.source + top + r * run.step;
  }
  return true;
}

// Per lane, values[row + below] (row: the lane's top row among the windows, 0 .. kRows - 2).
template <int kRows, class D, class VRow, class V = hn::Vec<D>>
HWY_INLINE V from_row(D d, VRow row, const V* values, int below) {
  const hn::DFromV<VRow> drow;
  V v = values[below];
  for (int r = 1; r + 1 < kRows; ++r) {
    const auto on = hn::RebindMask(d, hn::Eq(row, hn::Set(drow, static_cast<hn::TFromV<VRow>>(r))));
    v = hn::IfThenElse(on, values[r + below], v);
  }
  return v;
}

// Each pixel's left and right neighbours on every window row (lanes of d, which the shuffle
// indices fill), and 32 x the horizontal interpolation on its row `below` its top row.
template <int kRows, class D, class V = hn::Vec<D>>
struct WindowRows {
  V left[kRows], right[kRows];

  template <class D8, class Windows, class V8 = hn::Vec<D8>>
  HWY_INLINE WindowRows(D d, D8 du8, const Windows& windows, V8 left_index, V8 right_index) {
    for (int r = 0; r < kRows; ++r) {
      const V8 window = load_windows(du8, windows[r]);
      left[r] = hn::BitCast(d, hn::TableLookupBytesOr0(window, left_index));
      right[r] = hn::BitCast(d, hn::TableLookupBytesOr0(window, right_index));
    }
  }
  template <class VRow>
  HWY_INLINE V interpolated(D d, VRow row, V fx, int below) const {
    const V l = from_row<kRows>(d, row, left, below);
    const V r = from_row<kRows>(d, row, right, below);
    return hn::Add(hn::ShiftLeft<5>(l), hn::Mul(hn::Sub(r, l), fx));
  }
};

// 8-bit samples of Lanes(du16) pixels from pixel i, from kRows windows per block of 8: x, y
// their positions (the entries' halves), column and row their top-left neighbours in their
// block's windows.
template <int kRows, class DU16, class V = hn::Vec<DU16>>
HWY_INLINE void sample_windows_8(DU16 du16, const InteriorRun& run, int i,
                                 const std::uint8_t* const (*windows)[hn::MaxLanes(DU16()) / 8],
                                 V x, V y, V column, V row) {
  const hn::RebindToSigned<DU16> di16;
  const hn::Repartition<std::uint8_t, DU16> du8;
  const hn::Repartition<std::int32_t, DU16> di32;
  // Shuffle indices as int16 lanes: the low byte picks the sample, the high byte (0x80) gives 0.
  const auto zero_high = hn::Set(du16, 0x8000);
  const auto left_index = hn::BitCast(du8, hn::Or(column, zero_high));
  const auto right_index = hn::BitCast(du8, hn::Or(hn::Add(column, hn::Set(du16, 1)), zero_high));
  const WindowRows<kRows, decltype(di16)> rows(di16, du8, windows, left_index, right_index);
  const auto fx = hn::BitCast(di16, hn::And(x, hn::Set(du16, kSubpixelSteps - 1)));
  const auto fy = hn::BitCast(di16, hn::And(y, hn::Set(du16, kSubpixelSteps - 1)));
  // 1/32 units, at most 8160: int16.
  const auto upper = rows.interpolated(di16, row, fx, 0);
  const auto lower = rows.interpolated(di16, row, fx, 1);
  // The vertical one as int16 pair products: (32 - fy) upper + fy lower, the model's sum in
  // 1/1024 units. Interleave and the demotion below both work per 128-bit block (x86's pack,
  // one block when emulated), so the pixels come back in order.
  const auto wy0 = hn::Sub(hn::Set(di16, kSubpixelSteps), fy);
  const auto sums = [&](auto pairs, auto weights) {
    auto odd = hn::Zero(di32);
    const auto even = hn::ReorderWidenMulAccumulate(di32, pairs, weights, hn::Zero(di32), odd);
    const auto acc = hn::RearrangeToOddPlusEven(even, odd);
    return hn::ShiftRight<10>(hn::Add(acc, hn::Set(di32, 512)));  // round half up
  };
  const auto first_half =
      sums(hn::InterleaveLower(di16, upper, lower), hn::InterleaveLower(di16, wy0, fy));
  const auto second_half =
      sums(hn::InterleaveUpper(di16, upper, lower), hn::InterleaveUpper(di16, wy0, fy));
  const auto samples = hn::ReorderDemote2To(di16, first_half, second_half);
  const hn::Rebind<std::uint8_t, decltype(di16)> d_out;
  hn::StoreU(hn::DemoteTo(d_out, samples), d_out, static_cast<std::uint8_t*>(run.out) + i);
}

// 16-bit samples of Lanes(di32) pixels from pixel i, from kRows windows per block of 4 (as
// sample_windows_8, in int32 lanes: 32 x 32 x 65535 needs 27 bits).
template <int kRows, class DI32, class V = hn::Vec<DI32>,
          class VU = hn::Vec<hn::RebindToUnsigned<DI32>>>
HWY_INLINE void sample_windows_16(DI32 di32, const InteriorRun& run, int i,
                                  const std::uint8_t* const (*windows)[hn::MaxLanes(DI32()) / 4],
                                  V x, V y, VU column, VU row) {
  const hn::RebindToUnsigned<DI32> du32;
  const hn::Repartition<std::uint8_t, DI32> du8;
  // Shuffle indices per int32 lane: the left sample's two bytes (2 column, 2 column + 1), then
  // two bytes 0x80 (0); the right sample's two bytes further.
  const auto byte = hn::ShiftLeft<1>(column);
  const auto left_bytes = hn::Or(hn::Or(byte, hn::ShiftLeft<8>(hn::Add(byte, hn::Set(du32, 1)))),
                                 hn::Set(du32, 0x80800000u));
  const auto left_index = hn::BitCast(du8, left_bytes);
  const auto right_index = hn::BitCast(du8, hn::Add(left_bytes, hn::Set(du32, 0x0202u)));
  const WindowRows<kRows, DI32> rows(di32, du8, windows, left_index, right_index);
  const V fx = hn::And(x, hn::Set(di32, kSubpixelSteps - 1));
  const V fy = hn::And(y, hn::Set(di32, kSubpixelSteps - 1));
  const V upper = rows.interpolated(di32, row, fx, 0);
  const V lower = rows.interpolated(di32, row, fx, 1);
  const V acc = hn::Add(hn::ShiftLeft<5>(upper), hn::Mul(hn::Sub(lower, upper), fy));
  // Half to even, as remap_lanes.
  const V odd = hn::And(hn::ShiftRight<10>(acc), hn::Set(di32, 1));
  const V result = hn::ShiftRight<10>(hn::Add(hn::Add(acc, hn::Set(di32, 511)), odd));
  const hn::Rebind<std::uint16_t, DI32> d_out;
  hn::StoreU(hn::DemoteTo(d_out, result), d_out, static_cast<std::uint16_t*>(run.out) + i);
}

// Lanes(du16) output pixels of 8-bit grey from pixel `i` of the run, or false (nothing written)
// when a block does not fit its windows.
template <class DU16>
HWY_INLINE bool remap_grey8_by_windows(DU16 du16, const InteriorRun& run, int i) {
  constexpr int kBlockPixels = 8;
  const hn::Repartition<std::uint32_t, DU16> du32;
  const std::uint32_t* entries = run.entries + i;
  // The pixels' positions (x in the low, y in the high half of each entry), in pixel order.
  const auto lower_entries = hn::BitCast(du16, hn::LoadU(du32, entries));
  const auto upper_entries = hn::BitCast(du16, hn::LoadU(du32, entries + hn::Lanes(du32)));
  const auto x = hn::ConcatEven(du16, upper_entries, lower_entries);
  const auto y = hn::ConcatOdd(du16, upper_entries, lower_entries);
  const auto x0 = hn::ShiftRight<kFractionBits>(x);
  const auto y0 = hn::ShiftRight<kFractionBits>(y);
  // Broadcast works per block.
  const auto column = hn::Sub(x0, hn::Broadcast<0>(x0));
  const auto row = hn::Sub(y0, hn::Min(hn::Broadcast<0>(y0), hn::Broadcast<kBlockPixels - 1>(y0)));
  const int rows = window_rows(du16, column, row, kWindowBytes - 2);
  constexpr std::size_t kBlocks = hn::MaxLanes(DU16()) / kBlockPixels;
  const std::uint8_t* windows[kMaxWindowRows][kBlocks];
  if (rows == 0 || !block_windows<kBlockPixels, 1>(run, entries, rows, windows)) return false;
  if (rows == 3) {
    sample_windows_8<3>(du16, run, i, windows, x, y, column, row);
  } else {
    sample_windows_8<4>(du16, run, i, windows, x, y, column, row);
  }
  return true;
}

// The same for 16-bit grey: Lanes(di32) pixels, blocks of 4.
template <class DI32>
HWY_INLINE bool remap_grey16_by_windows(DI32 di32, const InteriorRun& run, int i) {
  constexpr int kBlockPixels = 4;
  const hn::RebindToUnsigned<DI32> du32;
  const std::uint32_t* entries = run.entries + i;
  const auto packed = hn::LoadU(du32, entries);
  const auto x = hn::And(packed, hn::Set(du32, 0xffffu));
  const auto y = hn::ShiftRight<16>(packed);
  const auto x0 = hn::ShiftRight<kFractionBits>(x);
  const auto y0 = hn::ShiftRight<kFractionBits>(y);
  const auto column = hn::Sub(x0, hn::Broadcast<0>(x0));
  const auto row = hn::Sub(y0, hn::Min(hn::Broadcast<0>(y0), hn::Broadcast<kBlockPixels - 1>(y0)));
  const int rows = window_rows(du32, column, row, kWindowBytes / 2 - 2);
  constexpr std::size_t kBlocks = hn::MaxLanes(DI32()) / kBlockPixels;
  const std::uint8_t* windows[kMaxWindowRows][kBlocks];
  if (rows == 0 || !block_windows<kBlockPixels, 2>(run, entries, rows, windows)) return false;
  const auto sx = hn::BitCast(di32, x);
  const auto sy = hn::BitCast(di32, y);
  if (rows == 3) {
    sample_windows_16<3>(di32, run, i, windows, sx, sy, column, row);
  } else {
    sample_windows_16<4>(di32, run, i, windows, sx, sy, column, row);
  }
  return true;
}
#endif

// How far ahead (output pixels) the kernel asks for the source lines it will read, and for
// which of a vector's pixels. A row of the pipeline's grid walks a curve through the source
// that changes source row every few pixels where it is steep, which the hardware prefetchers do
// not follow: without the hint every new line is a full memory latency (~100 ns). Measured on
// the rig's visible table (BGR, 936x566): no hints 7.1 ms, first and last pixel of the vector
// 4.3-5.2 ms, every second pixel 3.4-4.0 ms, every pixel 3.3-3.8 ms; distances 32-128 px alike.
constexpr int kPrefetchPixels = 64;
constexpr int kPrefetchEveryNthPixel = 2;

template <int PixelBytes, class D>
HWY_INLINE void prefetch_source_lines(D d, const InteriorRun& run, int i) {
  HWY_ALIGN std::int32_t offsets[hn::MaxLanes(D())];
  hn::Vec<D> x, y;
  load_entries(d, run, i, &x, &y);
  hn::Store(top_left_offsets<PixelBytes>(d, run, x, y), d, offsets);
  for (std::size_t k = 0; k < hn::Lanes(d); k += kPrefetchEveryNthPixel) {
    hwy::Prefetch(run.source + offsets[k]);
    hwy::Prefetch(run.source + offsets[k] + run.step);
  }
}

// The grey kernels' prefetch (remap_grey8_by_windows, remap_grey16_by_windows): the lines of five
// source rows from the top-left neighbour of the pixel kPrefetchPixels ahead, which also brings the
// rows the next output rows will cross into (a grid row reads each source row it meets first, cold:
// the bridge wrote it from another core). Measured on the full grid's luma (bench_remap_kernel's
// case 5, a new source each call: 16 copies in turn), median of 8: two rows 1.74-2.00 ms (as many
// as without the hint), three 1.19-1.44, four 1.13-1.17, five 1.03.
constexpr int kPrefetchWindowRows = 5;

template <int kPixelBytes>
HWY_INLINE void prefetch_windows(const InteriorRun& run, int i) {
  const std::uint32_t entry = run.entries[i];
  const std::uint8_t* top = run.source + top_left_offset<kPixelBytes>(run, entry, entry);
  for (int r = 0; r < kPrefetchWindowRows; ++r) hwy::Prefetch(top + r * run.step);
}

template <typename Sample, int Channels>
void remap_run(const InteriorRun& run) {
  constexpr int kPixelBytes = static_cast<int>(sizeof(Sample)) * Channels;
  const hn::ScalableTag<std::int32_t> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  int i = 0;
#if HWY_TARGET != HWY_SCALAR
  if constexpr (sizeof(Sample) == 1 && Channels == 1) {
    const hn::ScalableTag<std::uint16_t> d16;
    const int pixels = static_cast<int>(hn::Lanes(d16));  // a multiple of `lanes`
    for (; i + pixels <= run.count; i += pixels) {
      if (i + kPrefetchPixels < run.count) prefetch_windows<1>(run, i + kPrefetchPixels);
      if (remap_grey8_by_windows(d16, run, i)) continue;
      for (int k = 0; k < pixels; k += lanes) remap_lanes<Sample, Channels>(d, run, i + k);
    }
  } else if constexpr (sizeof(Sample) == 2 && Channels == 1) {
    for (; i + lanes <= run.count; i += lanes) {
      if (i + kPrefetchPixels < run.count) prefetch_windows<2>(run, i + kPrefetchPixels);
      if (!remap_grey16_by_windows(d, run, i)) remap_lanes<Sample, Channels>(d, run, i);
    }
  }
#endif
  for (; i + lanes <= run.count; i += lanes) {
    if (i + kPrefetchPixels + lanes <= run.count) {
      prefetch_source_lines<kPixelBytes>(d, run, i + kPrefetchPixels);
    }
    remap_lanes<Sample, Channels>(d, run, i);
  }
  if (i == run.count) return;
  if (run.count >= lanes) {
    // The tail as one more full vector ending at the run's end: it rewrites a few pixels with
    // the same values, cheaper than lane by lane.
    remap_lanes<Sample, Channels>(d, run, run.count - lanes);
    return;
  }
  const hn::CappedTag<std::int32_t, 1> d1;
  for (; i < run.count; ++i) remap_lanes<Sample, Channels>(d1, run, i);
}

void RemapInterior8UC1(const InteriorRun& run) { remap_run<std::uint8_t, 1>(run); }
void RemapInterior8UC3(const InteriorRun& run) { remap_run<std::uint8_t, 3>(run); }
void RemapInterior16UC1(const InteriorRun& run) { remap_run<std::uint16_t, 1>(run); }

}  // namespace HWY_NAMESPACE
}  // namespace thermovis::fpga::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace thermovis::fpga::detail {

HWY_EXPORT(RemapInterior8UC1);
HWY_EXPORT(RemapInterior8UC3);
HWY_EXPORT(RemapInterior16UC1);

void remap_interior_8uc1(const InteriorRun& run) { HWY_DYNAMIC_DISPATCH(RemapInterior8UC1)(run); }
void remap_interior_8uc3(const InteriorRun& run) { HWY_DYNAMIC_DISPATCH(RemapInterior8UC3)(run); }
void remap_interior_16uc1(const InteriorRun& run) { HWY_DYNAMIC_DISPATCH(RemapInterior16UC1)(run); }

}  // namespace thermovis::fpga::detail
#endif  // HWY_ONCE
