#include "thermovis/detect/person_detector.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>
#include <optional>
#include <stdexcept>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::detect {

namespace {

constexpr util::EnumName<Band> kBandNames[] = {
    {Band::infrared, "infrared"}, {Band::visible, "visible"}, {Band::fused, "fused"}};

constexpr util::EnumName<VisibleMethod> kVisibleMethodNames[] = {
    {VisibleMethod::hog, "hog"},
    {VisibleMethod::haar_fullbody, "haar-fullbody"},
    {VisibleMethod::haar_upperbody, "haar-upperbody"}};

}  // namespace

Band parse_band(const std::string& name) {
  if (const auto band = util::parse(kBandNames, name)) return *band;
  throw std::invalid_argument("band '" + name + "': expected " +
                              util::join_names(kBandNames, ", ", " or "));
}

std::string band_name(Band band) { return util::name_of(kBandNames, band, "?"); }

VisibleMethod parse_visible_method(const std::string& name) {
  if (const auto method = util::parse(kVisibleMethodNames, name)) return *method;
  throw std::invalid_argument("visible detector '" + name + "': expected " +
                              util::join_names(kVisibleMethodNames, ", ", " or "));
}

std::string visible_method_name(VisibleMethod method) {
  return util::name_of(kVisibleMethodNames, method, "?");
}

struct PersonDetector::Impl {
  PersonDetectorOptions options;
  cv::CascadeClassifier cascade;
  std::optional<InfraredClassifier> classifier;

  std::vector<Detection> detect_visible(const cv::Mat& visible) {
    const int side = std::max(visible.cols, visible.rows);
    const double scale = options.visible_max_side_px > 0 && side > options.visible_max_side_px
                             ? static_cast<double>(options.visible_max_side_px) / side
                             : 1.0;
    if (options.visible_method == VisibleMethod::hog) {
      HogOptions hog = options.hog;
      hog.scale = scale;
      return detect_people_hog(visible, hog);
    }
    cv::Mat grey, small;
    if (visible.channels() == 3) {
      cv::cvtColor(visible, grey, cv::COLOR_BGR2GRAY);
    } else {
      grey = visible;
    }
    if (scale == 1.0) {
      small = grey;
    } else {
      cv::resize(grey, small, cv::Size(), scale, scale, cv::INTER_AREA);
    }
    std::vector<cv::Rect> found;
    std::vector<int> reject_levels;
    std::vector<double> level_weights;
    cascade.detectMultiScale(small, found, reject_levels, level_weights, 1.05, 2, 0, cv::Size(),
                             cv::Size(), true);
    const bool upper = options.visible_method == VisibleMethod::haar_upperbody;
    std::vector<Detection> out;
    for (std::size_t i = 0; i < found.size(); ++i) {
      cv::Rect2d r(found[i].x / scale, found[i].y / scale, found[i].width / scale,
                   found[i].height / scale);
      // The upper-body cascade's window holds the head and shoulders (22 x 18): a standing
      // person is about three such heights tall and as wide as the shoulders.
      if (upper) r.height *= 3.0;
      Detection d;
      d.box = cv::Rect(cv::Point(cvRound(r.x), cvRound(r.y)),
                       cv::Point(cvRound(r.br().x), cvRound(r.br().y))) &
              cv::Rect(0, 0, visible.cols, visible.rows);
      d.score = i < level_weights.size() ? level_weights[i] : 0.0;
      d.source = "visible";
      if (!d.box.empty()) out.push_back(d);
    }
    return out;
  }

  std::vector<Detection> detect_infrared(const cv::Mat& infrared,
                                         const camera::RectifiedCamera* grid) const {
    if (!classifier)
      return merge_detections(detect_warm_blobs(infrared, grid, options.warm_blob),
                              options.nms_iou);
    const cv::Mat ir8 = infrared_to_8bit(infrared);
    std::vector<Candidate> candidates = infrared_candidates(ir8, options.candidates);
    if (grid != nullptr) {
      std::erase_if(candidates, [&](const Candidate& c) {
        return !height_fits_ground(c.box, *grid, options.warm_blob);
      });
    }
    const std::vector<double> scores = classifier->score(candidate_features(ir8, candidates));
    std::vector<Detection> out;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      if (scores[i] <= options.min_score) continue;
      Detection d;
      d.box = candidates[i].box;
      d.score = scores[i];
      d.source = "infrared";
      out.push_back(d);
    }
    return merge_detections(std::move(out), options.nms_iou);
  }
};

PersonDetector::PersonDetector(PersonDetectorOptions options) : impl_(std::make_unique<Impl>()) {
  impl_->options = std::move(options);
  const auto& o = impl_->options;
  if (o.band != Band::visible && !o.infrared_model.empty())
    impl_->classifier.emplace(o.infrared_model);
  if (o.band != Band::infrared && o.visible_method != VisibleMethod::hog) {
    const auto file = o.cascade_dir / (o.visible_method == VisibleMethod::haar_fullbody
                                           ? "haarcascade_fullbody.xml"
                                           : "haarcascade_upperbody.xml");
    if (!impl_->cascade.load(file.string())) {
      throw std::runtime_error(file.string() +
                               ": cannot read the cascade (Debian package opencv-data)");
    }
  }
}

PersonDetector::~PersonDetector() = default;
PersonDetector::PersonDetector(PersonDetector&&) noexcept = default;
PersonDetector& PersonDetector::operator=(PersonDetector&&) noexcept = default;

const PersonDetectorOptions& PersonDetector::options() const { return impl_->options; }

std::vector<Detection> PersonDetector::detect(const cv::Mat& infrared, const cv::Mat& visible,
                                              const camera::RectifiedCamera* grid) {
  const auto& o = impl_->options;
  const bool need_ir = o.band != Band::visible;
  const bool need_vis = o.band != Band::infrared;
  if (need_ir && infrared.empty())
    throw std::invalid_argument("detect: the " + band_name(o.band) +
                                " band needs an infrared image");
  if (need_vis && visible.empty())
    throw std::invalid_argument("detect: the " + band_name(o.band) + " band needs a visible image");
  if (!infrared.empty() && infrared.type() != CV_16UC1 && infrared.type() != CV_8UC1)
    throw std::invalid_argument("detect: infrared must be CV_16UC1 or CV_8UC1");
  if (!visible.empty() && visible.type() != CV_8UC1 && visible.type() != CV_8UC3)
    throw std::invalid_argument("detect: visible must be CV_8UC1 or CV_8UC3");
  if (!infrared.empty() && !visible.empty() && infrared.size() != visible.size())
    throw std::invalid_argument("detect: infrared and visible images differ in size");
  const cv::Mat& any = infrared.empty() ? visible : infrared;
  if (grid != nullptr && any.size() != grid->image_size())
    throw std::invalid_argument("detect: image size differs from the grid's");

  if (o.band == Band::infrared) return impl_->detect_infrared(infrared, grid);
  if (o.band == Band::visible) return merge_detections(impl_->detect_visible(visible), o.nms_iou);
  std::vector<Detection> ir = impl_->detect_infrared(infrared, grid);
  const std::vector<Detection> vis = impl_->detect_visible(visible);
  double lowest = 0.0;
  for (const Detection& d : ir) lowest = std::min(lowest, d.score);
  for (Detection& d : ir) {
    for (const Detection& v : vis) {
      if (intersection_over_union(d.box, v.box) >= o.fuse_iou) {
        d.score += o.fuse_bonus;
        break;
      }
    }
    d.source = "fused";
  }
  // Visible-only boxes rank below every infrared box, in their own order: a logistic maps the
  // visible score onto (lowest - 1, lowest).
  for (Detection v : vis) {
    v.score = lowest - 1.0 + 1.0 / (1.0 + std::exp(-v.score));
    v.source = "fused";
    ir.push_back(v);
  }
  return merge_detections(std::move(ir), o.nms_iou);
}

}  // namespace thermovis::detect
