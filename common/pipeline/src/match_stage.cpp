#include "thermovis/pipeline/match_stage.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "thermovis/range/ranging.hpp"
#include "thermovis/util/enum_names.hpp"

namespace thermovis::pipeline {
namespace {

constexpr util::EnumName<BandChoice> kBandChoiceNames[] = {{BandChoice::visible, "visible"},
                                                           {BandChoice::infrared, "infrared"},
                                                           {BandChoice::fused, "fused"},
                                                           {BandChoice::automatic, "auto"},
                                                           {BandChoice::both, "both"}};

// Counts of the region both eyes' searches look at, stretched linearly to 8 bits between the
// left region's 0.5 and 99.5 percentiles (the same mapping for both eyes).
void stretch_counts(const cv::Mat& left, const cv::Mat& right, cv::Mat& left8, cv::Mat& right8) {
  // The percentiles from a histogram of the counts between the region's extremes (exactly the
  // k-th smallest values a sort would give, without sorting).
  std::uint16_t vmin = 0xFFFF, vmax = 0;
  std::size_t n = 0;
  for (int r = 0; r < left.rows; ++r) {
    const auto* row = left.ptr<std::uint16_t>(r);
    for (int c = 0; c < left.cols; ++c) {
      if (row[c] == 0) continue;  // 0: outside the camera's field
      vmin = std::min(vmin, row[c]);
      vmax = std::max(vmax, row[c]);
      ++n;
    }
  }
  double lo = 0, hi = 1;
  if (n > 0) {
    std::vector<std::uint32_t> histogram(static_cast<std::size_t>(vmax - vmin) + 1, 0);
    for (int r = 0; r < left.rows; ++r) {
      const auto* row = left.ptr<std::uint16_t>(r);
      for (int c = 0; c < left.cols; ++c)
        if (row[c] != 0) ++histogram[row[c] - vmin];
    }
    const auto at = [&](double q) {
      const auto k = static_cast<std::size_t>(q * static_cast<double>(n - 1));
      std::size_t seen = 0;
      for (std::size_t v = 0; v < histogram.size(); ++v) {
        seen += histogram[v];
        if (seen > k) return static_cast<double>(vmin + v);
      }
      return static_cast<double>(vmax);
    };
    lo = at(0.005);
    hi = std::max(lo + 1.0, at(0.995));
  }
  const double gain = 255.0 / (hi - lo);
  left.convertTo(left8, CV_8U, gain, -lo * gain);
  right.convertTo(right8, CV_8U, gain, -lo * gain);
}

void check_pair(const cv::Mat& left, const cv::Mat& right, cv::Size grid, int type,
                const char* what) {
  if (left.size() != grid || right.size() != grid) {
    throw std::invalid_argument(std::string("match: the ") + what + " pair is not on the grid (" +
                                std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                                ", grid " + std::to_string(grid.width) + "x" +
                                std::to_string(grid.height) + ")");
  }
  if (left.type() != type || right.type() != type) {
    throw std::invalid_argument(std::string("match: the ") + what + " pair must be " +
                                (type == CV_16UC1 ? "16-bit counts" : "8-bit grey"));
  }
}

// The median disparity of the points, NaN for fewer than 3.
double median_disparity(const match::MatchResult& result) {
  if (result.matches.size() < 3) return std::numeric_limits<double>::quiet_NaN();
  std::vector<double> d;
  d.reserve(result.matches.size());
  for (const auto& c : result.matches) d.push_back(c.disparity_px);
  auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
  std::nth_element(d.begin(), mid, d.end());
  return *mid;
}

// A result measured on the infrared image reduced by k, in grid pixels: positions through
// grid_coordinate, disparities and row offsets times k (the row slope is a ratio), the box the
// grid's.
void result_to_grid(match::MatchResult& result, int k, const cv::Rect& grid_box) {
  const auto to_grid = [k](Eigen::Vector2d& p) {
    p = Eigen::Vector2d(grid_coordinate(p.x(), k), grid_coordinate(p.y(), k));
  };
  for (match::Correspondence& c : result.matches) {
    to_grid(c.left);
    to_grid(c.right);
    c.disparity_px *= k;
  }
  result.box = grid_box;
  result.row_offset_px *= k;
  match::RegionDisparity& q = result.region;
  q.disparity_px *= k;
  q.sigma_px *= k;
  q.row_offset_px *= k;
  if (q.anchor.allFinite()) to_grid(q.anchor);
}

// A silhouette found on the infrared image reduced by k (the mask of `reduced_box`) as the mask
// of `box` on the grid (nearest reduced pixel).
cv::Mat silhouette_on_grid(const cv::Mat& reduced_mask, const cv::Rect& reduced_box,
                           const cv::Rect& box, int k) {
  if (reduced_mask.empty()) return {};
  cv::Mat up;
  cv::resize(reduced_mask, up, cv::Size(reduced_mask.cols * k, reduced_mask.rows * k), 0, 0,
             cv::INTER_NEAREST);
  return up(cv::Rect(box.x - reduced_box.x * k, box.y - reduced_box.y * k, box.width, box.height))
      .clone();
}

}  // namespace

BandChoice parse_band_choice(const std::string& name) {
  if (const auto band = util::parse(kBandChoiceNames, name)) return *band;
  throw std::invalid_argument("unknown band '" + name + "' (" +
                              util::join_names(kBandChoiceNames, ", ", ", ") + ")");
}

std::pair<double, double> typical_height_m(const std::string& label) {
  if (label == "person") return {1.0, 2.1};
  return {0.0, 0.0};
}

MatchStage::MatchStage(const PipelineGeometry& geometry, const MatchStageOptions& options)
    : grid_size_(geometry.grid_size()),
      infrared_size_(geometry.image_size(Band::infrared)),
      infrared_reduction_(geometry.infrared_reduction),
      baseline_visible_m_(geometry.ranging(Band::visible).baseline_m),
      baseline_infrared_m_(geometry.ranging(Band::infrared).baseline_m),
      options_(options) {
  // A right eye at (Bx, By, Bz) of the left rectified frame sees a point of depth Z
  // -f By / Z rows from the left eye's row, at disparity f Bx / Z: -By / Bx rows per px.
  const Eigen::Vector3d c = geometry.ranging(Band::infrared).right_centre_m;
  if (c.x() > 0) infrared_rows_per_disparity_ = -c.y() / c.x();
  // The left infrared centre seen from the left visible one (both frames share the grid's
  // rotation): a point at depth Z is f (1/Z - 1/Z_reg) (dx, dy) further on the visible grid
  // than on the registered infrared image, f / Z being the visible disparity over its baseline.
  const Eigen::Vector3d delta =
      (geometry.visible.T_ref_left_rect.inverse() * geometry.infrared.T_ref_left_rect)
          .translation();
  if (baseline_visible_m_ > 0) {
    silhouette_shift_per_disparity_ = delta.head<2>() / baseline_visible_m_;
  }
  if (geometry.registration_distance_m > 0) {
    silhouette_shift_ = -geometry.grid.f * delta.head<2>() / geometry.registration_distance_m;
  }
  options_.match.min_disparity_px = 0.0;
  options_.match.max_disparity_px = max_disparity(geometry, options.min_distance_m);
  options_.region_options.min_disparity_px = options_.match.min_disparity_px;
  options_.region_options.max_disparity_px = options_.match.max_disparity_px;
  // The infrared pair is searched on its own image: the same range in its pixels.
  infrared_match_ = options_.match;
  infrared_match_.max_disparity_px /= infrared_reduction_;
  infrared_region_ = options_.region_options;
  infrared_region_.max_disparity_px = infrared_match_.max_disparity_px;
  infrared_region_.row_offset_per_disparity = infrared_rows_per_disparity_;
}

bool MatchStage::aligns(const match::MatchResult& result) const {
  if (!options_.region) return false;
  const int n = static_cast<int>(result.matches.size());
  if (n < options_.region_below_points) return true;
  if (n >= options_.region_split_below_points) return false;
  // A nearer group than the median's: what the range's screen would keep, with its window.
  static const range::RangeOptions screen;
  const double median = median_disparity(result);
  const double window = std::max(screen.group_disparity_px, screen.group_relative * median);
  int nearer = 0;
  for (const auto& c : result.matches) nearer += c.disparity_px > median + window;
  return nearer >= 3;
}

void MatchStage::align(Band band, const cv::Mat& left8, const cv::Mat& right8, const cv::Rect& box,
                       const cv::Mat& silhouette, std::pair<double, double> height_m,
                       match::MatchResult& result) const {
  if (!options_.region) return;
  if (!aligns(result)) {
    result.region.status = match::RegionStatus::not_aligned;
    result.region.message = "not aligned: the box's " + std::to_string(result.matches.size()) +
                            " point correspondences range it alone";
    return;
  }
  match::RegionOptions o = band == Band::infrared ? infrared_region_ : options_.region_options;
  const double start = median_disparity(result);
  if (result.ransac_inliers >= 3 && std::isfinite(start)) {
    // The points' row model already holds the offset at their disparity.
    o.row_offset_px = result.row_offset_px - o.row_offset_per_disparity * start;
  }
  if (!std::isfinite(start) && height_m.first > 0) {
    // The box's height h (px) of a target H m tall puts it at about f H / h, where the pair's
    // disparity is at most B h / H (less off the grid's centre: cos of the bearing). Bounds
    // widened for a box cut short (a target partly hidden) and for bearings up to 60 deg.
    const double B = band == Band::infrared ? baseline_infrared_m_ : baseline_visible_m_;
    const double h = box.height;
    o.min_disparity_px = std::max(o.min_disparity_px, 0.5 * B * h / height_m.second - 1.0);
    o.max_disparity_px = std::min(o.max_disparity_px, 1.3 * B * h / height_m.first + 1.0);
    if (o.max_disparity_px < o.min_disparity_px) o.max_disparity_px = o.min_disparity_px;
  }
  result.region = match::align_region(left8, right8, box, silhouette, start, o);
}

Band MatchStage::primary_band() const {
  switch (options_.band) {
    case BandChoice::fused:
      return Band::fused;
    case BandChoice::infrared:
      return Band::infrared;
    default:
      return Band::visible;
  }
}

bool MatchStage::uses_infrared() const {
  return options_.band == BandChoice::infrared || options_.band == BandChoice::automatic ||
         options_.band == BandChoice::both;
}

cv::Mat MatchStage::stage_grey(const cv::Mat& image) {
  cv::Mat grey;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.type() == CV_8UC1 || image.type() == CV_16UC1) {
    grey = image.clone();
  } else {
    throw std::invalid_argument("match: unsupported pixel type (BGR8, MONO8 or MONO16)");
  }
  return grey;
}

match::MatchResult MatchStage::match_on(Band band, const cv::Mat& left, const cv::Mat& right,
                                        const cv::Rect& box, const cv::Mat& infrared_left,
                                        std::pair<double, double> height_m) const {
  const bool silhouettes = options_.region && !infrared_left.empty();
  if (silhouettes && infrared_left.size() != infrared_size_) {
    throw std::invalid_argument("match: the infrared image is not on the infrared pair's grid");
  }
  if (band != Band::infrared) {
    check_pair(left, right, grid_size_, CV_8UC1, band == Band::fused ? "fused" : "visible");
    match::MatchResult result = match::match_box(left, right, box, options_.match);
    cv::Mat silhouette;
    if (silhouettes && aligns(result)) {
      // The infrared camera sees the target from its own centre: on the grid (registered at
      // registration_distance_m) its silhouette is displaced from the visible one by the
      // parallax at the target's distance, from the points' disparity or the box's height.
      double d = median_disparity(result);
      if (!std::isfinite(d) && height_m.first > 0) {
        d = baseline_visible_m_ * box.height / (0.5 * (height_m.first + height_m.second));
      }
      if (std::isfinite(d)) {
        const Eigen::Vector2d s = silhouette_shift_per_disparity_ * d + silhouette_shift_;
        const cv::Point shift(static_cast<int>(std::lround(s.x())),
                              static_cast<int>(std::lround(s.y())));
        const cv::Rect shifted = box - shift;
        const cv::Rect reduced = reduce_box(shifted, infrared_reduction_);
        silhouette = infrared_reduction_ == 1
                         ? match::target_silhouette(infrared_left, shifted)
                         : silhouette_on_grid(match::target_silhouette(infrared_left, reduced),
                                              reduced, shifted, infrared_reduction_);
      }
    }
    align(band, left, right, box, silhouette, height_m, result);
    return result;
  }
  check_pair(left, right, infrared_size_, CV_16UC1, "infrared");
  // On the infrared pair's own image (the grid reduced by k): the box's search region (the same
  // in both eyes, so disparities are kept) stretched to 8 bits, matched there, and the points
  // moved back to the whole image and onto the grid.
  const int k = infrared_reduction_;
  const cv::Rect ir_box = reduce_box(box, k);
  const int pad = infrared_match_.patch_radius + 8;
  const int reach = static_cast<int>(std::ceil(infrared_match_.max_disparity_px));
  const cv::Rect region = cv::Rect(ir_box.x - reach - pad, ir_box.y - pad,
                                   ir_box.width + reach + 2 * pad, ir_box.height + 2 * pad) &
                          cv::Rect(0, 0, left.cols, left.rows);
  if (region.empty()) return {};
  cv::Mat left8, right8;
  stretch_counts(left(region), right(region), left8, right8);
  match::MatchResult result =
      match::match_box(left8, right8, ir_box - region.tl(), infrared_match_);
  const cv::Mat silhouette =
      silhouettes && aligns(result) ? match::target_silhouette(left, ir_box) : cv::Mat();
  align(band, left8, right8, ir_box - region.tl(), silhouette, height_m, result);
  const Eigen::Vector2d offset(region.x, region.y);
  for (auto& c : result.matches) {
    c.left += offset;
    c.right += offset;
  }
  result.box += region.tl();
  result.region.anchor += offset;
  if (k > 1) result_to_grid(result, k, box & cv::Rect(cv::Point(0, 0), grid_size_));
  return result;
}

std::vector<BandMatches> MatchStage::match(const MatchImages& images, const cv::Rect& box,
                                           const std::string& label) const {
  const std::pair<double, double> height = typical_height_m(label);
  const bool has_primary = uses_primary() && !images.primary_left.empty();
  const bool has_infrared = uses_infrared() && !images.infrared_left.empty();
  // The target's silhouette comes from the infrared image of the grid, for both pairs' regions.
  const cv::Mat& silhouette =
      images.silhouette_infrared.empty() ? images.infrared_left : images.silhouette_infrared;
  std::vector<BandMatches> out;
  if (options_.band == BandChoice::infrared) {
    if (has_infrared) {
      out.push_back({Band::infrared, match_on(Band::infrared, images.infrared_left,
                                              images.infrared_right, box, silhouette, height)});
    }
    return out;
  }
  if (has_primary) {
    out.push_back({primary_band(), match_on(primary_band(), images.primary_left,
                                            images.primary_right, box, silhouette, height)});
  }
  if (!has_infrared) return out;
  if (options_.band == BandChoice::both) {
    out.push_back({Band::infrared, match_on(Band::infrared, images.infrared_left,
                                            images.infrared_right, box, silhouette, height)});
  } else if (options_.band == BandChoice::automatic &&
             (out.empty() ||
              static_cast<int>(out.front().result.matches.size()) < options_.min_visible_points)) {
    BandMatches infrared{Band::infrared, match_on(Band::infrared, images.infrared_left,
                                                  images.infrared_right, box, silhouette, height)};
    if (out.empty() || infrared.result.matches.size() > out.front().result.matches.size()) {
      out.assign(1, std::move(infrared));
    }
  }
  return out;
}

std::vector<std::vector<BandMatches>> MatchStage::match_each(const MatchImages& images,
                                                             const std::vector<Box>& boxes) const {
  std::vector<std::vector<BandMatches>> out(boxes.size());
  std::vector<std::exception_ptr> errors(boxes.size());
  const auto run = [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      const auto k = static_cast<std::size_t>(i);
      try {
        out[k] = match(images, boxes[k].box, boxes[k].label);
      } catch (...) {
        errors[k] = std::current_exception();
      }
    }
  };
  const int n = static_cast<int>(boxes.size());
  // One box per piece: their costs differ by far more than the scheduling's (a near person
  // has hundreds of points, a far one a region alignment).
  if (n > 1 && cv::getNumThreads() > 1) {
    cv::parallel_for_(cv::Range(0, n), run, n);
  } else {
    run(cv::Range(0, n));
  }
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  return out;
}

}  // namespace thermovis::pipeline
