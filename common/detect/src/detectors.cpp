#include "thermovis/detect/detectors.hpp"

#include <algorithm>
#include <cmath>
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

std::vector<Detection> detect_warm_blobs(const cv::Mat& infrared,
                                         const camera::RectifiedCamera& grid,
                                         const WarmBlobOptions& options) {
  return detect_warm_blobs(infrared, &grid, options);
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
  if (samples.size() < 16) return {};
  auto median_of = [](std::vector<float> v) {
    auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return static_cast<double>(*mid);
  };
  const double median = median_of(samples);
  for (float& v : samples) v = std::abs(v - static_cast<float>(median));
  const double sigma = 1.4826 * median_of(samples);
  const double threshold = median + std::max(o.k_sigma * sigma, o.min_excess_counts);
  // Compared in the image's own type (no float copy of the frame): above the threshold means
  // above its integer part.
  cv::Mat mask;
  cv::compare(infrared, cv::Scalar(std::floor(threshold)), mask, cv::CMP_GT);
  const cv::Mat& values = infrared;
  cv::morphologyEx(mask, mask, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, {3, 5}));
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<Detection> out;
  for (int i = 1; i < n; ++i) {
    const cv::Rect box(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
                       stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
    if (stats.at<int>(i, cv::CC_STAT_AREA) < o.min_area_px) continue;
    const double aspect = static_cast<double>(box.height) / box.width;
    if (aspect < o.min_aspect || aspect > o.max_aspect) continue;
    if (grid != nullptr && !height_fits_ground(box, *grid, o)) continue;
    const double mean = cv::mean(values(box), mask(box))[0];
    Detection d;
    d.box = box;
    d.score = sigma > 0 ? (mean - threshold) / sigma : 1.0;
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
