#include "thermovis/detect/detectors.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>
#include <stdexcept>

namespace thermovis::detect {

double intersection_over_union(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  const double uni = a.area() + b.area() - inter;
  return uni > 0 ? inter / uni : 0.0;
}

bool height_fits_ground(const cv::Rect& box, const camera::RectifiedCamera& grid,
                        const WarmBlobOptions& o) {
  // Known geometry: the foot row's angle below the horizon gives the ground distance, and a
  // person there is person_height_m tall (angular height on the grid's rows).
  const auto& g = grid.intrinsics();
  const double below = (box.br().y - 0.5 - g.cy) / g.f;  // rad below the horizon
  if (below <= 0.0) return false;                        // foot above the horizon
  const double distance = o.camera_height_m / std::tan(below);
  const double top = std::atan2(o.camera_height_m - o.person_height_m, distance);  // rad below
  const double expected = (below - top) * g.f;
  const double ratio = box.height / expected;
  return ratio >= o.height_ratio_min && ratio <= o.height_ratio_max;
}

std::vector<Component> label_components(const cv::Mat& mask, cv::Mat& labels) {
  if (mask.type() != CV_8UC1) throw std::invalid_argument("label_components: mask must be CV_8UC1");
  const int n = cv::connectedComponents(mask, labels, 8, CV_32S);
  struct Extent {
    int x0 = INT_MAX, y0 = INT_MAX, x1 = -1, y1 = -1, area = 0;
  };
  std::vector<Extent> extents(static_cast<std::size_t>(std::max(n - 1, 0)));
  for (int y = 0; y < mask.rows; ++y) {
    const std::uint8_t* m = mask.ptr<std::uint8_t>(y);
    const int* l = labels.ptr<int>(y);
    int x = 0;
    while (x < mask.cols) {
      // Masks are mostly empty: eight unset pixels at a time.
      if (x + 8 <= mask.cols) {
        std::uint64_t word;
        std::memcpy(&word, m + x, sizeof word);
        if (word == 0) {
          x += 8;
          continue;
        }
      }
      const int end = std::min(x + 8, mask.cols);
      for (; x < end; ++x) {
        if (m[x] == 0) continue;
        Extent& e = extents[static_cast<std::size_t>(l[x] - 1)];
        e.x0 = std::min(e.x0, x);
        e.x1 = std::max(e.x1, x);
        e.y0 = std::min(e.y0, y);
        e.y1 = y;  // rows come in order
        ++e.area;
      }
    }
  }
  std::vector<Component> out;
  out.reserve(extents.size());
  for (const Extent& e : extents) {
    out.push_back({cv::Rect(e.x0, e.y0, e.x1 - e.x0 + 1, e.y1 - e.y0 + 1), e.area});
  }
  return out;
}

std::vector<Detection> detect_warm_blobs(const cv::Mat& infrared,
                                         const camera::RectifiedCamera& grid,
                                         const WarmBlobOptions& options) {
  return detect_warm_blobs(infrared, &grid, options);
}

WarmMask warm_blob_mask(const cv::Mat& infrared, const WarmBlobOptions& o) {
  if (infrared.type() != CV_16UC1 && infrared.type() != CV_8UC1) {
    throw std::invalid_argument("warm_blob_mask: infrared must be CV_16UC1 or CV_8UC1");
  }
  // Background statistics over the pixels inside the field (value > 0), on a subsample.
  std::vector<float> samples;
  samples.reserve(static_cast<std::size_t>(infrared.total() / 16 + 1));
  for (int y = 0; y < infrared.rows; y += 4) {
    for (int x = 0; x < infrared.cols; x += 4) {
      const float v = infrared.depth() == CV_16U ? infrared.at<std::uint16_t>(y, x)
                                                 : infrared.at<std::uint8_t>(y, x);
      if (v > 0) samples.push_back(v);
    }
  }
  WarmMask out;
  if (samples.size() < 16) return out;
  auto median_of = [](std::vector<float> v) {
    auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return static_cast<double>(*mid);
  };
  const double median = median_of(samples);
  for (float& v : samples) v = std::abs(v - static_cast<float>(median));
  out.sigma = 1.4826 * median_of(samples);
  out.threshold = median + std::max(o.k_sigma * out.sigma, o.min_excess_counts);
  // Compared in the image's own type (no float copy of the frame): above the threshold means
  // above its integer part.
  cv::compare(infrared, cv::Scalar(std::floor(out.threshold)), out.mask, cv::CMP_GT);
  cv::morphologyEx(out.mask, out.mask, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_RECT, {3, 5}));
  return out;
}

std::vector<Detection> detect_warm_blobs(const cv::Mat& infrared,
                                         const camera::RectifiedCamera* grid,
                                         const WarmBlobOptions& o) {
  if (infrared.type() != CV_16UC1 && infrared.type() != CV_8UC1) {
    throw std::invalid_argument("detect_warm_blobs: infrared must be CV_16UC1 or CV_8UC1");
  }
  if (grid != nullptr && infrared.size() != grid->image_size()) {
    throw std::invalid_argument("detect_warm_blobs: image size differs from the grid's");
  }
  const WarmMask warm = warm_blob_mask(infrared, o);
  if (warm.mask.empty()) return {};
  cv::Mat labels;
  std::vector<Detection> out;
  for (const Component& c : label_components(warm.mask, labels)) {
    const cv::Rect& box = c.box;
    if (c.area_px < o.min_area_px) continue;
    const double aspect = static_cast<double>(box.height) / box.width;
    if (aspect < o.min_aspect || aspect > o.max_aspect) continue;
    if (grid != nullptr && !height_fits_ground(box, *grid, o)) continue;
    const double mean = cv::mean(infrared(box), warm.mask(box))[0];
    Detection d;
    d.box = box;
    d.score = warm.sigma > 0 ? (mean - warm.threshold) / warm.sigma : 1.0;
    d.source = "infrared";
    out.push_back(d);
  }
  return out;
}

std::vector<Detection> detect_people_hog(const cv::Mat& visible, const HogOptions& o) {
  if (visible.type() != CV_8UC1 && visible.type() != CV_8UC3) {
    throw std::invalid_argument("detect_people_hog: visible must be CV_8UC1 or CV_8UC3");
  }
  if (!(o.scale > 0.0 && o.scale <= 2.0))
    throw std::invalid_argument("detect_people_hog: scale in (0, 2]");
  cv::Mat small;
  if (o.scale == 1.0) {
    small = visible;
  } else {
    cv::resize(visible, small, cv::Size(), o.scale, o.scale, cv::INTER_AREA);
  }
  cv::HOGDescriptor hog;
  // An image smaller than the detector's window (64 x 128) holds no person it can see.
  if (small.cols < hog.winSize.width || small.rows < hog.winSize.height) return {};
  hog.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
  std::vector<cv::Rect> found;
  std::vector<double> weights;
  hog.detectMultiScale(small, found, weights, o.hit_threshold, cv::Size(8, 8), cv::Size(),
                       o.pyramid_scale, 2.0);
  std::vector<Detection> out;
  for (size_t i = 0; i < found.size(); ++i) {
    const cv::Rect& r = found[i];
    Detection d;
    // The default detector's window has a margin around the person: about 1/8 on each side
    // horizontally and 1/16 vertically.
    const double x = r.x + r.width * 0.125, y = r.y + r.height * 0.0625;
    const double w = r.width * 0.75, h = r.height * 0.875;
    d.box = cv::Rect(static_cast<int>(x / o.scale), static_cast<int>(y / o.scale),
                     static_cast<int>(w / o.scale), static_cast<int>(h / o.scale));
    d.score = i < weights.size() ? weights[i] : 0.0;
    d.source = "visible";
    out.push_back(d);
  }
  return out;
}

std::vector<Detection> merge_detections(std::vector<Detection> detections, double iou) {
  std::sort(detections.begin(), detections.end(),
            [](const Detection& a, const Detection& b) { return a.score > b.score; });
  std::vector<Detection> kept;
  for (const Detection& d : detections) {
    bool overlaps = false;
    for (const Detection& k : kept)
      overlaps = overlaps || intersection_over_union(d.box, k.box) > iou;
    if (!overlaps) kept.push_back(d);
  }
  return kept;
}

}  // namespace thermovis::detect
