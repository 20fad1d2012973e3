#include "thermovis/detect/infrared_classifier.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <opencv2/ml.hpp>
#include <opencv2/objdetect.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace thermovis::detect {

namespace {

// The field (counts > 0) of a 16-bit frame on a 1-in-16 subsample, as a histogram of its
// counts: its order statistics without sorting the samples.
class FieldHistogram {
 public:
  explicit FieldHistogram(const cv::Mat& counts) : bins_(std::size_t{1} << 16, 0) {
    for (int y = 0; y < counts.rows; y += 4) {
      const std::uint16_t* row = counts.ptr<std::uint16_t>(y);
      for (int x = 0; x < counts.cols; x += 4) {
        if (row[x] == 0) continue;
        ++bins_[row[x]];
        ++samples_;
      }
    }
  }
  std::size_t samples() const { return samples_; }
  // The sample at position floor(p / 100 x (samples - 1)) of the sorted samples (what
  // std::nth_element at that position gives). Needs samples() > 0.
  double percentile(double p) const {
    const auto n = static_cast<double>(samples_);
    const auto k = static_cast<std::size_t>(std::clamp(p / 100.0 * (n - 1.0), 0.0, n - 1.0));
    std::size_t below = 0;  // samples in the bins before v
    for (std::size_t v = 0; v < bins_.size(); ++v) {
      below += bins_[v];
      if (below > k) return static_cast<double>(v);
    }
    return static_cast<double>(bins_.size() - 1);
  }

 private:
  std::vector<std::uint32_t> bins_;
  std::size_t samples_ = 0;
};

struct FieldStats {
  double median = 0, sigma = 1, top = 0;
  bool valid = false;
};

// The grey level below which the share p (percent) of a histogram's count lies.
double histogram_percentile(const std::array<double, 256>& histogram, double total, double p) {
  const double want = p / 100.0 * (total - 1.0);
  double below = 0;
  for (int v = 0; v < 256; ++v) {
    below += histogram[static_cast<std::size_t>(v)];
    if (below > want) return v;
  }
  return 255;
}

// Median, robust sigma (1.4826 MAD) and a top percentile of the field (pixels > 0) of an 8-bit
// frame, from its histogram on a 1-in-16 subsample.
FieldStats field_stats(const cv::Mat& ir8, double top_percentile) {
  std::array<double, 256> histogram{};
  double total = 0;
  for (int y = 0; y < ir8.rows; y += 4) {
    const std::uint8_t* row = ir8.ptr<std::uint8_t>(y);
    for (int x = 0; x < ir8.cols; x += 4) {
      if (row[x] == 0) continue;
      histogram[row[x]] += 1;
      total += 1;
    }
  }
  FieldStats f;
  if (total < 16) return f;
  f.top = histogram_percentile(histogram, total, top_percentile);
  f.median = histogram_percentile(histogram, total, 50.0);
  std::array<double, 256> deviation{};
  for (int v = 1; v < 256; ++v)
    deviation[static_cast<std::size_t>(std::abs(v - static_cast<int>(f.median)))] +=
        histogram[static_cast<std::size_t>(v)];
  f.sigma = std::max(1.0, 1.4826 * histogram_percentile(deviation, total, 50.0));
  f.valid = true;
  return f;
}

// Features of a candidate beyond HOG (all without units: ratios and grey levels in robust
// sigmas of the field), then the HOG window.
constexpr int kShapeFeatures = 10;
const cv::Size kWindow(20, 20);
constexpr double kMargin = 0.25;  // context around the box, in box sizes on each side

int feature_count() {
  return kShapeFeatures + static_cast<int>(classifier_hog().getDescriptorSize());
}

cv::Rect grown(const cv::Rect& box, double margin) {
  const int mx = static_cast<int>(std::ceil(box.width * margin));
  const int my = static_cast<int>(std::ceil(box.height * margin));
  return {box.x - mx, box.y - my, box.width + 2 * mx, box.height + 2 * my};
}

// The image inside rect, the parts outside the image filled by replicating its edge.
cv::Mat crop_replicate(const cv::Mat& image, const cv::Rect& rect) {
  const cv::Rect inside = rect & cv::Rect(0, 0, image.cols, image.rows);
  cv::Mat out;
  cv::copyMakeBorder(image(inside), out, inside.y - rect.y, rect.br().y - inside.br().y,
                     inside.x - rect.x, rect.br().x - inside.br().x, cv::BORDER_REPLICATE);
  return out;
}

// The rows (or columns) of own that hold a pixel within [from, to) of the other axis: the
// extent [first, last] along the axis, or first > last when there is none.
std::pair<int, int> extent_along(const cv::Mat& own, bool rows, int from, int to) {
  const cv::Mat part = rows ? own.colRange(from, to) : own.rowRange(from, to);
  cv::Mat profile;
  cv::reduce(part, profile, rows ? 1 : 0, cv::REDUCE_MAX);
  const int n = static_cast<int>(profile.total());
  const std::uint8_t* p = profile.ptr<std::uint8_t>();
  int first = 0, last = n - 1;
  while (first < n && p[first] == 0) ++first;
  while (last >= first && p[last] == 0) --last;
  return {first, last};
}

// Person-shaped windows across (wide) or down (tall) a component's box, each fitted to the
// component's pixels inside it (own: the component's mask over its box).
void add_split_windows(const cv::Mat& own, const cv::Rect& box, const Candidate& parent,
                       const CandidateOptions& o, std::vector<Candidate>& out) {
  if (std::max(box.width, box.height) < o.split_min_px) return;
  const bool wide = box.width > o.split_wide * box.height;
  const bool tall = box.height > o.split_tall * box.width;
  if (!wide && !tall) return;
  const int along = wide ? box.width : box.height;   // the axis the windows slide on
  const int across = wide ? box.height : box.width;  // the other one
  for (const double r : wide ? o.split_widths : o.split_heights) {
    const int size = static_cast<int>(std::lround(r * across));
    if (size < 2 || size >= 0.85 * along) continue;
    const int stride = std::max(1, size / 3);
    for (int a = 0;; a += stride) {
      a = std::min(a, along - size);
      const auto [first, last] = extent_along(own, wide, a, a + size);
      if (first <= last) {
        const cv::Rect local = wide ? cv::Rect(a, first, size, last - first + 1)
                                    : cv::Rect(first, a, last - first + 1, size);
        const double filled = cv::countNonZero(own(local));
        if (filled >= o.split_min_fill * local.area() && local.height >= o.min_height_px) {
          Candidate c = parent;
          c.box = local + box.tl();
          c.area_px = filled;
          c.growth = 0.0;
          c.split = true;
          out.push_back(c);
        }
      }
      if (a + size >= along) break;
    }
  }
}

void add_components(const cv::Mat& ir8, const cv::Rect& roi, const cv::Mat& inside,
                    const std::vector<double>& thresholds, int level, double parent_area,
                    const CandidateOptions& o, std::vector<Candidate>& out) {
  cv::Mat mask;
  cv::compare(ir8(roi), cv::Scalar(thresholds[static_cast<std::size_t>(level)]), mask, cv::CMP_GT);
  if (!inside.empty()) mask &= inside;
  cv::Mat labels;
  const std::vector<Component> components = label_components(mask, labels);
  const double too_large = o.max_frame_fraction * static_cast<double>(ir8.total());
  for (std::size_t k = 0; k < components.size(); ++k) {
    const int i = static_cast<int>(k) + 1;  // its label
    const double area = components[k].area_px;
    if (area < o.min_area_px) continue;
    const cv::Rect& local = components[k].box;
    const cv::Rect box = local + roi.tl();
    cv::Mat own;
    cv::compare(labels(local), cv::Scalar(i), own, cv::CMP_EQ);
    if (area <= too_large && box.height >= o.min_height_px) {
      Candidate c;
      c.level = level;
      c.area_px = area;
      c.threshold = thresholds[static_cast<std::size_t>(level)];
      c.parent_area_px = level == 0 ? area : parent_area;
      // The component and boxes grown around it: a threshold's outline lies inside the
      // person's (cooler edges, clothing), by more at warmer levels.
      for (const double g : o.box_growth) {
        c.box = grown(box, g) & cv::Rect(0, 0, ir8.cols, ir8.rows);
        c.growth = g;
        out.push_back(c);
      }
      add_split_windows(own, box, c, o, out);
    }
    if (level + 1 < static_cast<int>(thresholds.size())) {
      add_components(ir8, box, own, thresholds, level + 1, area, o, out);
    }
  }
}

}  // namespace

cv::Mat infrared_to_8bit(const cv::Mat& infrared) {
  if (infrared.type() == CV_8UC1) return infrared;
  if (infrared.type() != CV_16UC1)
    throw std::invalid_argument("infrared_to_8bit: infrared must be CV_16UC1 or CV_8UC1");
  const FieldHistogram field(infrared);
  cv::Mat out(infrared.size(), CV_8UC1, cv::Scalar(0));
  if (field.samples() < 16) return out;
  const double lo = field.percentile(1.0);
  const double hi = std::max(lo + 1.0, field.percentile(99.9));
  const double gain = 254.0 / (hi - lo);
  infrared.convertTo(out, CV_8U, gain, 1.0 - lo * gain);
  cv::max(out, 1, out);
  out.setTo(0, infrared == 0);
  return out;
}

std::vector<Candidate> infrared_candidates(const cv::Mat& ir8, const CandidateOptions& o) {
  if (ir8.type() != CV_8UC1) throw std::invalid_argument("infrared_candidates: needs CV_8UC1");
  if (o.levels < 1) throw std::invalid_argument("infrared_candidates: levels >= 1");
  const FieldStats f = field_stats(ir8, o.top_percentile);
  if (!f.valid) return {};
  const double first = f.median + o.first_k_sigma * f.sigma;
  if (first >= 255.0) return {};
  const double top = std::max(f.top, first + o.levels);
  std::vector<double> thresholds;
  for (int i = 0; i < o.levels; ++i)
    thresholds.push_back(std::floor(first + (top - first) * i / o.levels));
  std::vector<Candidate> out;
  add_components(ir8, cv::Rect(0, 0, ir8.cols, ir8.rows), cv::Mat(), thresholds, 0, 0.0, o, out);
  return out;
}

// Sums of an 8-bit image over rectangles with fractional edges, from its integral image: the
// pixels are constant over their unit squares, so the integral is bilinear within each one.
class AreaSums {
 public:
  explicit AreaSums(const cv::Mat& ir8) { cv::integral(ir8, integral_, CV_32S); }
  double at(double x, double y) const {  // sum over [0, x) x [0, y)
    const int x0 = std::min(static_cast<int>(x), integral_.cols - 2);
    const int y0 = std::min(static_cast<int>(y), integral_.rows - 2);
    const double fx = x - x0, fy = y - y0;
    const int* r0 = integral_.ptr<int>(y0);
    const int* r1 = integral_.ptr<int>(y0 + 1);
    return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
           fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
  }
  double sum(const cv::Rect& r) const {
    const int* top = integral_.ptr<int>(r.y);
    const int* bottom = integral_.ptr<int>(r.y + r.height);
    return static_cast<double>(bottom[r.x + r.width]) - bottom[r.x] - top[r.x + r.width] + top[r.x];
  }
  // The mean over each of size's cells of rect (inside the image): what cv::resize with
  // INTER_AREA gives when it shrinks in both directions.
  void shrink(const cv::Rect& rect, cv::Size size, cv::Mat& out) const {
    out.create(size, CV_8UC1);
    const double sx = static_cast<double>(rect.width) / size.width;
    const double sy = static_cast<double>(rect.height) / size.height;
    const double norm = 1.0 / (sx * sy);
    // The integral at the cells' corners, each once (a corner is shared by up to four cells);
    // a cell's sum is at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0), in that order.
    const int w = size.width + 1;
    corners_.resize(static_cast<std::size_t>(w) * (size.height + 1));
    for (int i = 0; i <= size.height; ++i) {
      const double y = rect.y + i * sy;
      for (int j = 0; j < w; ++j)
        corners_[static_cast<std::size_t>(i * w + j)] = at(rect.x + j * sx, y);
    }
    for (int i = 0; i < size.height; ++i) {
      std::uint8_t* row = out.ptr<std::uint8_t>(i);
      const double* top = corners_.data() + static_cast<std::ptrdiff_t>(i) * w;
      const double* bottom = top + w;
      for (int j = 0; j < size.width; ++j) {
        const double cell = bottom[j + 1] - bottom[j] - top[j + 1] + top[j];
        row[j] = cv::saturate_cast<std::uint8_t>(cell * norm);
      }
    }
  }

 private:
  cv::Mat integral_;
  mutable std::vector<double> corners_;  // shrink's scratch
};

namespace {

struct BoxStats {
  double mean = 0, sd = 0, max = 0;
};

// The mean, standard deviation and maximum of an 8-bit box in one pass (what cv::meanStdDev and
// cv::minMaxLoc give; those two calls cost more than the pass on the small boxes of most
// candidates).
BoxStats box_stats(const cv::Mat& box) {
  std::uint64_t sum = 0, squares = 0;
  std::uint8_t top = 0;
  for (int y = 0; y < box.rows; ++y) {
    const std::uint8_t* row = box.ptr<std::uint8_t>(y);
    std::uint32_t row_sum = 0, row_squares = 0;
    for (int x = 0; x < box.cols; ++x) {
      const std::uint32_t v = row[x];
      row_sum += v;
      row_squares += v * v;
      top = std::max(top, row[x]);
    }
    sum += row_sum;
    squares += row_squares;
  }
  BoxStats s;
  const double n = static_cast<double>(box.total());
  if (n == 0) return s;
  s.mean = static_cast<double>(sum) / n;
  s.sd = std::sqrt(std::max(0.0, static_cast<double>(squares) / n - s.mean * s.mean));
  s.max = top;
  return s;
}

constexpr int kMosaicColumns = 64;           // at most this many windows per row of the mosaic
constexpr std::size_t kMosaicWindows = 128;  // candidate_features' windows per mosaic

// Windows per row: as many rows as kMosaicColumns needs, the windows spread evenly over them
// (the gradients are computed over the whole mosaic: a last row of few windows would waste up
// to a row of tiles).
int mosaic_columns(int windows) {
  if (windows <= 0) return 1;
  const int rows = (windows + kMosaicColumns - 1) / kMosaicColumns;
  return (windows + rows - 1) / rows;
}

}  // namespace

cv::HOGDescriptor classifier_hog() {
  return cv::HOGDescriptor(kWindow, cv::Size(10, 10), cv::Size(5, 5), cv::Size(5, 5), 9);
}

HogMosaic::HogMosaic(const cv::HOGDescriptor& hog, int windows)
    : hog_(hog),
      windows_(std::max(windows, 0)),
      tile_(hog.winSize.width + 2, hog.winSize.height + 2),
      columns_(mosaic_columns(windows_)),
      mosaic_((windows_ + columns_ - 1) / columns_ * tile_.height, columns_ * tile_.width, CV_8UC1,
              cv::Scalar(0)),
      scratch_(hog.winSize, CV_8UC1) {
  locations_.reserve(static_cast<std::size_t>(windows_));
  for (int i = 0; i < windows_; ++i) {
    locations_.emplace_back((i % columns_) * tile_.width + 1, (i / columns_) * tile_.height + 1);
  }
}

void HogMosaic::set(int i) {
  if (i < 0 || i >= windows_) {
    throw std::out_of_range("HOG mosaic: window " + std::to_string(i) + " of " +
                            std::to_string(windows_));
  }
  if (scratch_.type() != CV_8UC1 || scratch_.size() != hog_.winSize) {
    throw std::invalid_argument("HOG mosaic: the window is not an 8-bit image of the HOG's size");
  }
  const cv::Point at = locations_[static_cast<std::size_t>(i)] - cv::Point(1, 1);
  cv::Mat framed = mosaic_(cv::Rect(at, tile_));
  cv::copyMakeBorder(scratch_, framed, 1, 1, 1, 1, cv::BORDER_REFLECT_101);
}

std::vector<float> HogMosaic::compute() const {
  std::vector<float> descriptors;
  if (windows_ == 0) return descriptors;
  hog_.compute(mosaic_, descriptors, cv::Size(), cv::Size(), locations_);
  if (descriptors.size() != static_cast<std::size_t>(windows_) * hog_.getDescriptorSize()) {
    throw std::logic_error("HOG mosaic: " + std::to_string(descriptors.size()) + " values for " +
                           std::to_string(windows_) + " windows");
  }
  return descriptors;
}

cv::Mat candidate_features(const cv::Mat& ir8, const std::vector<Candidate>& candidates) {
  if (ir8.type() != CV_8UC1) throw std::invalid_argument("candidate_features: needs CV_8UC1");
  cv::Mat features(static_cast<int>(candidates.size()), feature_count(), CV_32F, cv::Scalar(0));
  if (candidates.empty()) return features;
  const FieldStats f = field_stats(ir8, 99.9);
  const cv::HOGDescriptor hog = classifier_hog();
  const AreaSums sums(ir8);
  const cv::Rect image(0, 0, ir8.cols, ir8.rows);
  // The HOGs kMosaicWindows windows at a time: such a mosaic (62 kB, its gradients about
  // 0.6 MB) stays in the core's cache; one mosaic of an LLVIP frame's 1400 windows (gradients
  // about 7 MB) was no faster than one call per window.
  const std::size_t size = hog.getDescriptorSize();
  std::optional<HogMosaic> mosaic;
  std::size_t first = 0;  // the mosaic's first candidate
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (i % kMosaicWindows == 0) {
      first = i;
      mosaic.emplace(hog, static_cast<int>(std::min(kMosaicWindows, candidates.size() - i)));
    }
    cv::Mat& window = mosaic->scratch();
    const Candidate& c = candidates[i];
    const cv::Rect outer = grown(c.box, kMargin);
    // The box with its margin on the window: inside the image and shrinking both ways, its
    // cells' means straight from the integral image (cv::resize's INTER_AREA, without copying
    // the patch); else the patch with replicated edges, resized.
    double patch_sum = 0;
    if ((outer & image) == outer && outer.width > kWindow.width && outer.height > kWindow.height) {
      sums.shrink(outer, kWindow, window);
      patch_sum = sums.sum(outer);
    } else {
      const cv::Mat patch = crop_replicate(ir8, outer);
      cv::resize(patch, window, kWindow, 0, 0,
                 patch.cols > kWindow.width ? cv::INTER_AREA : cv::INTER_LINEAR);
      patch_sum = cv::sum(patch)[0];
    }
    mosaic->set(static_cast<int>(i - first));
    const BoxStats box = box_stats(ir8(c.box));
    const double ring_area = static_cast<double>(outer.area()) - c.box.area();
    const double ring_mean = ring_area > 0 ? (patch_sum - sums.sum(c.box)) / ring_area : box.mean;
    float* row = features.ptr<float>(static_cast<int>(i));
    row[0] = static_cast<float>(std::log(static_cast<double>(c.box.height) / c.box.width));
    row[1] = static_cast<float>(c.area_px / c.box.area());
    row[2] = static_cast<float>((box.mean - ring_mean) / f.sigma);
    row[3] = static_cast<float>((box.max - c.threshold) / f.sigma);
    row[4] = static_cast<float>((box.mean - f.median) / f.sigma);
    row[5] = static_cast<float>(c.level);
    row[6] = static_cast<float>(c.area_px / std::max(1.0, c.parent_area_px));
    row[7] = static_cast<float>(box.sd / f.sigma);
    row[8] = static_cast<float>(c.growth);
    row[9] = c.split ? 1.0F : 0.0F;
    if (i + 1 == candidates.size() || (i + 1) % kMosaicWindows == 0) {
      const std::vector<float> descriptors = mosaic->compute();
      for (std::size_t k = first; k <= i; ++k) {
        const auto from = descriptors.begin() + static_cast<std::ptrdiff_t>((k - first) * size);
        std::copy(from, from + static_cast<std::ptrdiff_t>(size),
                  features.ptr<float>(static_cast<int>(k)) + kShapeFeatures);
      }
    }
  }
  return features;
}

struct InfraredClassifier::Impl {
  cv::Ptr<cv::ml::Boost> person, fit;
};

namespace {

constexpr const char* kPersonNode = "person";
constexpr const char* kFitNode = "fit";

cv::Ptr<cv::ml::Boost> load_boost(const std::filesystem::path& model, const char* node) {
  cv::Ptr<cv::ml::Boost> boost;
  try {
    boost = cv::Algorithm::load<cv::ml::Boost>(model.string(), node);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(model.string() + ": not an OpenCV boosted-trees model: " + e.what());
  }
  if (boost.empty() || !boost->isTrained()) {
    throw std::runtime_error(model.string() + ": holds no trained boosted-trees model \"" + node +
                             "\" (retrain with detect-train)");
  }
  if (boost->getVarCount() != feature_count()) {
    throw std::runtime_error(model.string() + ": \"" + node + "\" made for " +
                             std::to_string(boost->getVarCount()) + " features, these are " +
                             std::to_string(feature_count()) + " (retrain with detect-train)");
  }
  return boost;
}

}  // namespace

InfraredClassifier::InfraredClassifier(const std::filesystem::path& model)
    : impl_(std::make_unique<Impl>()) {
  if (!std::filesystem::is_regular_file(model))
    throw std::runtime_error(model.string() + ": no model file");
  impl_->person = load_boost(model, kPersonNode);
  impl_->fit = load_boost(model, kFitNode);
}

InfraredClassifier::~InfraredClassifier() = default;
InfraredClassifier::InfraredClassifier(InfraredClassifier&&) noexcept = default;
InfraredClassifier& InfraredClassifier::operator=(InfraredClassifier&&) noexcept = default;

std::vector<double> InfraredClassifier::score(const cv::Mat& features) const {
  constexpr int kVotes = static_cast<int>(cv::ml::DTrees::PREDICT_SUM) |
                         static_cast<int>(cv::ml::StatModel::RAW_OUTPUT);
  std::vector<double> out;
  out.reserve(static_cast<std::size_t>(features.rows));
  for (int i = 0; i < features.rows; ++i) {
    const cv::Mat row = features.row(i);
    // The person model's vote plus the fit model's, which ranks the box that fits a person
    // above its parts and groups (measured on both halves of the annotated sets, against the
    // fit vote only for boxes the person model takes and against the product of the two
    // probabilities: the plain sum ranks best).
    out.push_back(impl_->person->predict(row, cv::noArray(), kVotes) +
                  impl_->fit->predict(row, cv::noArray(), kVotes));
  }
  return out;
}

int collect_training_samples(const cv::Mat& infrared, const std::vector<cv::Rect>& persons,
                             const std::vector<cv::Rect>& dont_care,
                             const CandidateOptions& candidate_options,
                             const TrainingOptions& options, std::vector<TrainingSample>& samples) {
  const cv::Mat ir8 = infrared_to_8bit(infrared);
  const std::vector<Candidate> candidates = infrared_candidates(ir8, candidate_options);
  const cv::Mat features = candidate_features(ir8, candidates);
  std::vector<bool> found(persons.size(), false);
  std::vector<TrainingSample> negatives;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    double best = 0.0;
    for (std::size_t k = 0; k < persons.size(); ++k) {
      const double o = intersection_over_union(candidates[i].box, persons[k]);
      if (o >= options.positive_iou) found[k] = true;
      best = std::max(best, o);
    }
    bool at_dont_care = false;
    for (const cv::Rect& d : dont_care) {
      const double o = intersection_over_union(candidates[i].box, d);
      if (o >= options.positive_iou || (best < options.positive_iou && o >= options.negative_iou))
        at_dont_care = true;
    }
    if (at_dont_care) continue;
    TrainingSample sample{features.row(static_cast<int>(i)).clone(),
                          best >= options.positive_iou ? 1 : 0, best};
    // Background alone is thinned; candidates about a person are all kept (the fit model's).
    if (sample.label == 0 && best < options.fit_min_iou)
      negatives.push_back(std::move(sample));
    else
      samples.push_back(std::move(sample));
  }
  const std::size_t keep =
      options.max_negatives_per_frame > 0
          ? std::min(negatives.size(), static_cast<std::size_t>(options.max_negatives_per_frame))
          : negatives.size();
  for (std::size_t k = 0; k < keep; ++k) samples.push_back(negatives[k * negatives.size() / keep]);
  return static_cast<int>(std::count(found.begin(), found.end(), true));
}

namespace {

// Boosted trees trained on the samples `use` accepts, a sample's class its label.
cv::Ptr<cv::ml::Boost> train_boost(const std::vector<TrainingSample>& samples, int weak_count,
                                   int max_depth, const char* what,
                                   const std::function<bool(const TrainingSample&)>& use) {
  std::vector<int> rows;
  int positives = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (!use(samples[i])) continue;
    rows.push_back(static_cast<int>(i));
    positives += samples[i].label;
  }
  if (positives == 0 || positives == static_cast<int>(rows.size())) {
    throw std::invalid_argument(std::string("train_infrared_classifier: the ") + what +
                                " model needs samples of both classes");
  }
  cv::Mat data(static_cast<int>(rows.size()), feature_count(), CV_32F);
  cv::Mat responses(static_cast<int>(rows.size()), 1, CV_32S);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const TrainingSample& s = samples[static_cast<std::size_t>(rows[k])];
    s.features.copyTo(data.row(static_cast<int>(k)));
    responses.at<int>(static_cast<int>(k)) = s.label;
  }
  auto boost = cv::ml::Boost::create();
  boost->setBoostType(cv::ml::Boost::REAL);
  boost->setWeakCount(weak_count);
  boost->setMaxDepth(max_depth);
  boost->setWeightTrimRate(0.95);
  boost->setUseSurrogates(false);
  boost->train(cv::ml::TrainData::create(data, cv::ml::ROW_SAMPLE, responses));
  return boost;
}

}  // namespace

void train_infrared_classifier(const std::vector<TrainingSample>& samples,
                               const TrainingOptions& options, const std::filesystem::path& model) {
  const auto person = train_boost(
      samples, options.weak_count, options.max_depth, kPersonNode,
      [&](const TrainingSample& s) { return s.label == 1 || s.person_iou < options.negative_iou; });
  const auto fit = train_boost(
      samples, options.fit_weak_count, options.max_depth, kFitNode,
      [&](const TrainingSample& s) { return s.label == 1 || s.person_iou >= options.fit_min_iou; });
  cv::FileStorage fs(model.string(), cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw std::runtime_error(model.string() + ": cannot be written");
  fs << kPersonNode << "{";
  person->write(fs);
  fs << "}" << kFitNode << "{";
  fit->write(fs);
  fs << "}";
}

}  // namespace thermovis::detect
