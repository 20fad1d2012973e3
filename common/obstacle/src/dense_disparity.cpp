#include "thermovis/obstacle/dense_disparity.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "thermovis/obstacle/block_matching.hpp"
#include "thermovis/util/enum_names.hpp"

namespace thermovis::obstacle {

namespace {

constexpr util::EnumName<DenseMethod> kMethodNames[] = {{DenseMethod::block_matching, "bm"},
                                                        {DenseMethod::semi_global, "sgbm"}};

void check_grey(const cv::Mat& image, const char* eye) {
  if (image.empty()) throw std::invalid_argument(std::string("dense disparity: no ") + eye);
  if (image.type() != CV_8UC1) {
    throw std::invalid_argument(std::string("dense disparity: the ") + eye +
                                " image is not CV_8UC1");
  }
}

// The local detail of infrared counts: each pixel less its 9 x 9 mean (the image's border
// reflected, 101), as float, the same to the bit as converting to float, cv::blur and
// subtracting: the float box filter sums in double, and sums of counts are integers that double
// holds exactly in any order, so the integer window sums times 1/81 are its means. One pass per
// row (column sums slid down the rows, then the window slid along them), no float images.
void local_detail(const cv::Mat& counts, cv::Mat& detail) {
  constexpr int kRadius = 4, kWindow = 2 * kRadius + 1;
  const int rows = counts.rows, cols = counts.cols;
  detail.create(counts.size(), CV_32F);
  // Reflected indices of the rows and columns a window reaches past the image.
  auto source_index = [](int i, int n) {
    return cv::borderInterpolate(i, n, cv::BORDER_REFLECT_101);
  };
  std::vector<int> column_sums(static_cast<std::size_t>(cols), 0);
  std::vector<int> column_of(static_cast<std::size_t>(cols + 2 * kRadius));
  std::vector<int> prefix(column_of.size() + 1, 0);
  for (int i = 0; i < static_cast<int>(column_of.size()); ++i) {
    column_of[static_cast<std::size_t>(i)] = source_index(i - kRadius, cols);
  }
  for (int dr = -kRadius; dr <= kRadius; ++dr) {
    const auto* src = counts.ptr<std::uint16_t>(source_index(dr, rows));
    for (int c = 0; c < cols; ++c) column_sums[static_cast<std::size_t>(c)] += src[c];
  }
  const double scale = 1.0 / (kWindow * kWindow);
  for (int r = 0; r < rows; ++r) {
    if (r > 0) {
      const auto* in = counts.ptr<std::uint16_t>(source_index(r + kRadius, rows));
      const auto* out = counts.ptr<std::uint16_t>(source_index(r - 1 - kRadius, rows));
      for (int c = 0; c < cols; ++c) column_sums[static_cast<std::size_t>(c)] += in[c] - out[c];
    }
    // Running sums along the reflected row, so each window's sum is a difference of two and
    // the loop below has no chain from pixel to pixel (it vectorises).
    int running = 0;
    for (std::size_t i = 0; i < column_of.size(); ++i) {
      prefix[i + 1] = running += column_sums[static_cast<std::size_t>(column_of[i])];
    }
    const auto* src = counts.ptr<std::uint16_t>(r);
    auto* d = detail.ptr<float>(r);
    const int* window_end = prefix.data() + kWindow;
    const int* window_start = prefix.data();
    for (int c = 0; c < cols; ++c) {
      const int sum = window_end[c] - window_start[c];
      d[c] = static_cast<float>(src[c]) - static_cast<float>(sum * scale);
    }
  }
}

}  // namespace

std::string method_name(DenseMethod method) { return util::name_of(kMethodNames, method, "?"); }

DenseMethod parse_dense_method(const std::string& name) {
  if (const auto m = util::parse(kMethodNames, name)) return *m;
  throw std::invalid_argument("unknown dense disparity method '" + name + "' (expected " +
                              util::join_names(kMethodNames, ", ", " or ") + ")");
}

double image_noise_sigma(const cv::Mat& grey) {
  check_grey(grey, "noise");
  if (grey.rows < 3 || grey.cols < 3) return 0.0;
  // Immerkaer (1996): the difference of two Laplacians cancels intensity that is planar over
  // 3 x 3 px; on white noise of sigma s its response has the standard deviation 6 s, so its
  // mean absolute value is sqrt(2 / pi) 6 s. Texture adds to it (an upper bound).
  // The kernel (1 -2 1; -2 4 -2; 1 -2 1) is the outer product of (1 -2 1) with itself: per
  // inner pixel the row filter's values of the rows above, at and below, in integers (exact,
  // as the float filter's sums of small integers are), summed in one pass without images.
  const int cols = grey.cols;
  std::vector<int> above(static_cast<std::size_t>(cols)), at(above.size()), below(above.size());
  auto row_filter = [cols](const std::uint8_t* src, std::vector<int>& out) {
    for (int c = 1; c + 1 < cols; ++c) {
      out[static_cast<std::size_t>(c)] = src[c - 1] - 2 * src[c] + src[c + 1];
    }
  };
  row_filter(grey.ptr<std::uint8_t>(0), above);
  row_filter(grey.ptr<std::uint8_t>(1), at);
  long long sum = 0;
  for (int r = 1; r + 1 < grey.rows; ++r) {
    row_filter(grey.ptr<std::uint8_t>(r + 1), below);
    for (int c = 1; c + 1 < cols; ++c) {
      const auto i = static_cast<std::size_t>(c);
      sum += std::abs(above[i] - 2 * at[i] + below[i]);
    }
    std::swap(above, at);
    std::swap(at, below);
  }
  const long long count = static_cast<long long>(grey.rows - 2) * (cols - 2);
  // cv::mean's scaling of its (here exact) sum: the same value as the filter2D version.
  const double mean_abs = static_cast<double>(sum) * (1. / static_cast<double>(count));
  return mean_abs / (6.0 * std::sqrt(2.0 / M_PI));
}

int block_texture_threshold(const cv::Mat& left, const DenseOptions& options) {
  if (!(options.texture_noise_factor > 0)) return options.texture_threshold;
  // StereoBM's texture of a block: the sum over it of its x Sobel's magnitude (clipped at the
  // pre-filter's cap, which noise does not reach). The x Sobel of white noise of sigma s has
  // the standard deviation sqrt(12) s, so a mean magnitude of sqrt(2 / pi) sqrt(12) s.
  const double sigma = image_noise_sigma(left);
  const double noise_texture =
      options.block_size * options.block_size * std::sqrt(2.0 / M_PI) * std::sqrt(12.0) * sigma;
  return std::max(options.texture_threshold,
                  static_cast<int>(std::lround(options.texture_noise_factor * noise_texture)));
}

double textured_share(const cv::Mat& left, const DenseOptions& options) {
  check_grey(left, "left");
  const int b = options.block_size;
  if (left.rows < b || left.cols < b) return 0.0;
  // StereoBM's texture of a block: the sum over it of its pre-filter's magnitude, the x Sobel
  // clipped at the cap (31). In integers, as cv::Sobel, abs, min and a box filter give it
  // exactly: the magnitude per pixel (the image's border reflected, 101, as Sobel does), then
  // the sums of the blocks inside the image (column sums slid down the rows, running sums
  // along them), counted where they reach the threshold.
  const int rows = left.rows, cols = left.cols, half = b / 2;
  std::vector<std::uint8_t> magnitude(static_cast<std::size_t>(rows) * cols);
  for (int r = 0; r < rows; ++r) {
    const auto* up =
        left.ptr<std::uint8_t>(cv::borderInterpolate(r - 1, rows, cv::BORDER_REFLECT_101));
    const auto* at = left.ptr<std::uint8_t>(r);
    const auto* down =
        left.ptr<std::uint8_t>(cv::borderInterpolate(r + 1, rows, cv::BORDER_REFLECT_101));
    std::uint8_t* m = magnitude.data() + static_cast<std::size_t>(r) * cols;
    auto sobel = [&](int c, int before, int after) {
      const int x =
          (up[after] - up[before]) + 2 * (at[after] - at[before]) + (down[after] - down[before]);
      m[c] = static_cast<std::uint8_t>(std::min(std::abs(x), 31));
    };
    sobel(0, 1, 1);
    for (int c = 1; c + 1 < cols; ++c) sobel(c, c - 1, c + 1);
    sobel(cols - 1, cols - 2, cols - 2);
  }
  const int threshold = block_texture_threshold(left, options);
  std::vector<int> column_sums(static_cast<std::size_t>(cols), 0),
      prefix(column_sums.size() + 1, 0);
  auto add_row = [&](int r, int sign) {
    const std::uint8_t* m = magnitude.data() + static_cast<std::size_t>(r) * cols;
    for (int c = 0; c < cols; ++c) column_sums[static_cast<std::size_t>(c)] += sign * m[c];
  };
  for (int r = 0; r < b; ++r) add_row(r, 1);
  long long textured = 0;
  for (int y = half; y + half < rows; ++y) {
    if (y > half) {
      add_row(y + half, 1);
      add_row(y - half - 1, -1);
    }
    int running = 0;
    for (int c = 0; c < cols; ++c)
      prefix[static_cast<std::size_t>(c) + 1] = running += column_sums[static_cast<std::size_t>(c)];
    for (int x = half; x + half < cols; ++x) {
      textured += prefix[static_cast<std::size_t>(x + half + 1)] -
                      prefix[static_cast<std::size_t>(x - half)] >=
                  threshold;
    }
  }
  const double inner = static_cast<double>(rows - b + 1) * (cols - b + 1);
  return static_cast<double>(textured) / inner;
}

cv::Mat dense_disparity(const cv::Mat& left, const cv::Mat& right, double max_disparity_px,
                        const DenseOptions& options) {
  check_grey(left, "left");
  check_grey(right, "right");
  if (left.size() != right.size()) {
    throw std::invalid_argument("dense disparity: the left and right images differ in size");
  }
  if (!(max_disparity_px > 0) || !std::isfinite(max_disparity_px)) {
    throw std::invalid_argument("dense disparity: the largest disparity is not > 0");
  }
  if (options.block_size < 5 || options.block_size % 2 == 0) {
    throw std::invalid_argument("dense disparity: block size " +
                                std::to_string(options.block_size) + " is not odd and >= 5");
  }
  const int range = 16 * static_cast<int>(std::ceil(max_disparity_px / 16.0));
  cv::Mat fixed;  // CV_16S, 1/16 px
  if (options.method == DenseMethod::block_matching) {
    const BlockMatchParams block{range, options.block_size, block_texture_threshold(left, options),
                                 options.uniqueness_ratio, 31};
    if (block_match_supported(left, right, block)) {
      block_match(left, right, block, fixed);  // StereoBM's result to the bit
    } else {
      // What block_match does not cover (a block over 21 px, an image smaller than the block):
      // OpenCV's, with its own checks. One matcher per thread, kept: it keeps its work buffers
      // from call to call. Every setting is made again below, so nothing of the last call's
      // options stays.
      thread_local const cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(range, options.block_size);
      bm->setNumDisparities(range);
      bm->setBlockSize(options.block_size);
      bm->setUniquenessRatio(options.uniqueness_ratio);
      bm->setTextureThreshold(block.texture_threshold);
      bm->setSpeckleWindowSize(0);  // below, for both
      bm->setPreFilterCap(block.prefilter_cap);
      bm->compute(left, right, fixed);
    }
    // StereoBM's speckle filter, as it runs it on its own result.
    if (options.speckle_window > 0 && options.speckle_range_px >= 0) {
      thread_local cv::Mat speckle_buffer;
      cv::filterSpeckles(fixed, kBlockMatchNone, options.speckle_window,
                         16 * options.speckle_range_px, speckle_buffer);
    }
  } else {
    const int b = options.block_size;
    auto sgbm = cv::StereoSGBM::create(
        0, range, b, 8 * b * b, 32 * b * b, 1, 31, options.uniqueness_ratio, options.speckle_window,
        16 * options.speckle_range_px, cv::StereoSGBM::MODE_SGBM_3WAY);
    sgbm->compute(left, right, fixed);
  }
  cv::Mat out(fixed.size(), CV_32F);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int r = 0; r < fixed.rows; ++r) {
    const auto* in = fixed.ptr<short>(r);
    auto* o = out.ptr<float>(r);
    for (int c = 0; c < fixed.cols; ++c) o[c] = in[c] > 0 ? static_cast<float>(in[c]) / 16.f : nan;
  }
  return out;
}

void grey_pair(const cv::Mat& left, const cv::Mat& right, cv::Mat& left8, cv::Mat& right8) {
  if (left.empty() || right.empty()) throw std::invalid_argument("grey pair: an eye is empty");
  if (left.size() != right.size() || left.type() != right.type()) {
    throw std::invalid_argument("grey pair: the eyes differ in size or type");
  }
  switch (left.type()) {
    case CV_8UC1:
      left8 = left;
      right8 = right;
      return;
    case CV_8UC3:
      cv::cvtColor(left, left8, cv::COLOR_BGR2GRAY);
      cv::cvtColor(right, right8, cv::COLOR_BGR2GRAY);
      return;
    case CV_16UC1: {
      // Infrared counts: a scene spans tens of kelvin and a road's texture a fraction of one,
      // so a linear stretch leaves the texture a few grey levels. The local detail (the image
      // less its 9 x 9 mean) is kept instead, at one gain for both eyes: 3 robust sigmas of the
      // left eye's detail over 64 grey levels. Pixels outside the cameras' field (0) stay flat.
      cv::Mat lf, rf;
      local_detail(left, lf);
      local_detail(right, rf);
      std::vector<float> detail;
      detail.reserve(left.total() / 4 + 1);
      for (int r = 0; r < left.rows; r += 2) {
        const auto* src = left.ptr<std::uint16_t>(r);
        const auto* d = lf.ptr<float>(r);
        for (int c = 0; c < left.cols; c += 2) {
          if (src[c] != 0) detail.push_back(std::abs(d[c]));
        }
      }
      float spread = 1.0f;
      if (!detail.empty()) {
        const auto mid = detail.begin() + static_cast<std::ptrdiff_t>(detail.size() / 2);
        std::nth_element(detail.begin(), mid, detail.end());
        spread = std::max(1.4826f * *mid, 1e-3f);
      }
      double gain = 64.0 / (3.0 * spread);
      lf.convertTo(left8, CV_8U, gain, 128.0);
      left8.setTo(128, left == 0);
      // Where the detail is mostly the cameras' noise (a road without texture of its own, at
      // night: its detail is their fixed pattern) that stretch gives the noise itself about 20
      // grey levels, and block matching's texture (the x Sobel clipped at 31, summed over a
      // block) saturates on noise and on edges alike: no threshold tells them apart. The gain
      // is then lowered until the noise is kMaxCountsNoiseGrey, so that what stands out of
      // the noise (a warm body's outline) has the texture noise has not.
      const double noise = image_noise_sigma(left8);
      if (noise > kMaxCountsNoiseGrey) {
        gain *= kMaxCountsNoiseGrey / noise;
        lf.convertTo(left8, CV_8U, gain, 128.0);
        left8.setTo(128, left == 0);
      }
      rf.convertTo(right8, CV_8U, gain, 128.0);
      right8.setTo(128, right == 0);
      return;
    }
    default:
      throw std::invalid_argument("grey pair: images are neither CV_8UC1, CV_8UC3 nor CV_16UC1");
  }
}

DenseAccuracy evaluate_dense(const cv::Mat& disparity, const cv::Mat& ground_truth) {
  if (disparity.type() != CV_32FC1 || ground_truth.type() != CV_32FC1 ||
      disparity.size() != ground_truth.size()) {
    throw std::invalid_argument(
        "evaluate_dense: the disparity and the truth are not CV_32FC1 of one size");
  }
  DenseAccuracy a;
  int valid = 0, bad1 = 0, bad2 = 0, bad1_valid = 0, bad2_valid = 0;
  for (int r = 0; r < disparity.rows; ++r) {
    const auto* d = disparity.ptr<float>(r);
    const auto* t = ground_truth.ptr<float>(r);
    for (int c = 0; c < disparity.cols; ++c) {
      if (!std::isfinite(t[c]) || !(t[c] > 0)) continue;
      ++a.truth_pixels;
      if (!std::isfinite(d[c])) {
        ++bad1;
        ++bad2;
        continue;
      }
      ++valid;
      const float e = std::abs(d[c] - t[c]);
      bad1 += e > 1.0f;
      bad2 += e > 2.0f;
      bad1_valid += e > 1.0f;
      bad2_valid += e > 2.0f;
    }
  }
  if (a.truth_pixels == 0) return a;
  const double n = a.truth_pixels;
  a.valid = valid / n;
  a.bad1 = bad1 / n;
  a.bad2 = bad2 / n;
  a.bad1_valid = valid ? static_cast<double>(bad1_valid) / valid : 0.0;
  a.bad2_valid = valid ? static_cast<double>(bad2_valid) / valid : 0.0;
  return a;
}

}  // namespace thermovis::obstacle
