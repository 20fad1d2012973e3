#include "thermovis/range/stereo_ranger.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "thermovis/enhance/infrared_agc.hpp"
#include "thermovis/rectify/rig_rectification.hpp"

namespace thermovis::range {

std::string mode_name(Mode mode) {
  switch (mode) {
    case Mode::visible:
      return "visible";
    case Mode::infrared:
      return "infrared";
    case Mode::fused:
      return "fused";
  }
  return "unknown";
}

Mode parse_mode(const std::string& name) {
  if (name == "visible") return Mode::visible;
  if (name == "infrared") return Mode::infrared;
  if (name == "fused") return Mode::fused;
  throw std::invalid_argument("unknown ranging mode '" + name +
                              "' (expected visible, infrared or fused)");
}

double surface_to_centre_m(const std::string& target_class) {
  if (target_class == "person") return 0.15 * M_PI / 4;
  if (target_class == "pole") return 0.10 * M_PI / 4;
  if (target_class == "marker") return 0.05 * 2.0 / 3.0;
  return 0.0;
}

struct StereoRanger::Impl {
  camera::Rig rig;
  rectify::RectifiedPair visible, infrared;
  RangingGeometry visible_geometry, infrared_geometry;

  Impl(const camera::Rig& r)
      : rig(r),
        visible(rectify::rectify_pair(r, r.visible, camera::RectifiedProjection::equirectangular)),
        infrared(
            rectify::rectify_pair(r, r.infrared, camera::RectifiedProjection::equirectangular)),
        visible_geometry{visible.geometry.grid, visible.geometry.baseline_m,
                         visible.geometry.T_ref_left_rect},
        infrared_geometry{infrared.geometry.grid, infrared.geometry.baseline_m,
                          infrared.geometry.T_ref_left_rect} {}
};

StereoRanger::StereoRanger(const camera::Rig& rig) : impl_(std::make_unique<Impl>(rig)) {}
StereoRanger::~StereoRanger() = default;
StereoRanger::StereoRanger(StereoRanger&&) noexcept = default;
StereoRanger& StereoRanger::operator=(StereoRanger&&) noexcept = default;

const RangingGeometry& StereoRanger::geometry(Mode mode) const {
  return mode == Mode::infrared ? impl_->infrared_geometry : impl_->visible_geometry;
}

namespace {

cv::Mat grey_of(const cv::Mat& image, const camera::RigCamera& camera, const char* what) {
  if (image.empty()) throw std::invalid_argument(std::string("ranging: no ") + what + " image");
  if (image.size() != camera.model->image_size()) {
    throw std::invalid_argument(std::string("ranging: ") + what + " image is " +
                                std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                ", camera " + camera.name + " is " +
                                std::to_string(camera.model->image_size().width) + "x" +
                                std::to_string(camera.model->image_size().height));
  }
  if (image.type() == CV_8UC1) return image;
  if (image.type() == CV_8UC3) {
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    return grey;
  }
  throw std::invalid_argument(std::string("ranging: ") + what + " image must be 8-bit grey or BGR");
}

cv::Mat agc_of(const cv::Mat& image, const camera::RigCamera& camera, const char* what) {
  if (image.empty()) throw std::invalid_argument(std::string("ranging: no ") + what + " image");
  if (image.size() != camera.model->image_size()) {
    throw std::invalid_argument(std::string("ranging: ") + what +
                                " image size differs from camera " + camera.name);
  }
  if (image.type() != CV_16UC1 && image.type() != CV_8UC1) {
    throw std::invalid_argument(std::string("ranging: ") + what +
                                " image must be CV_16UC1 counts or CV_8UC1");
  }
  enhance::AgcParams params;
  params.temporal_alpha = 1.0;  // each frame on its own
  enhance::InfraredAgc agc(params);
  return agc.process(image);
}

cv::Mat remap_with(const cv::Mat& image, const cv::Mat& map) {
  cv::Mat out;
  cv::remap(image, out, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  return out;
}

}  // namespace

RectifiedFrames StereoRanger::rectify(const RawFrames& raw) const {
  const camera::Rig& rig = impl_->rig;
  RectifiedFrames out;
  out.visible_left =
      remap_with(grey_of(raw.visible_left, rig.camera(rig.visible.left), "visible left"),
                 impl_->visible.left_map);
  out.visible_right =
      remap_with(grey_of(raw.visible_right, rig.camera(rig.visible.right), "visible right"),
                 impl_->visible.right_map);
  out.infrared_left =
      remap_with(agc_of(raw.infrared_left, rig.camera(rig.infrared.left), "infrared left"),
                 impl_->infrared.left_map);
  if (raw.infrared_left.type() == CV_16UC1) {
    out.infrared_counts_left = remap_with(raw.infrared_left, impl_->infrared.left_map);
  }
  out.infrared_right =
      remap_with(agc_of(raw.infrared_right, rig.camera(rig.infrared.right), "infrared right"),
                 impl_->infrared.right_map);
  return out;
}

cv::Rect raw_box_on_grid(const camera::RigCamera& cam, const Eigen::Isometry3d& T_ref_rect,
                         const camera::RectifiedCamera& grid, double x_min, double y_min,
                         double x_max, double y_max) {
  const Eigen::Matrix3d R_rect_cam = T_ref_rect.rotation().transpose() * cam.T_ref_cam.rotation();
  double lo_x = 1e30, lo_y = 1e30, hi_x = -1e30, hi_y = -1e30;
  const int steps = 16;
  for (int i = 0; i <= steps; ++i) {
    const double t = static_cast<double>(i) / steps;
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(x_min + t * (x_max - x_min), y_min),
                                     Eigen::Vector2d(x_min + t * (x_max - x_min), y_max),
                                     Eigen::Vector2d(x_min, y_min + t * (y_max - y_min)),
                                     Eigen::Vector2d(x_max, y_min + t * (y_max - y_min))}) {
      Eigen::Vector3d ray;
      Eigen::Vector2d q;
      if (!cam.model->unproject(p, ray) || !grid.project(R_rect_cam * ray, q)) continue;
      lo_x = std::min(lo_x, q.x());
      lo_y = std::min(lo_y, q.y());
      hi_x = std::max(hi_x, q.x());
      hi_y = std::max(hi_y, q.y());
    }
  }
  if (lo_x > hi_x) return {};
  const int x0 = static_cast<int>(std::floor(lo_x)), y0 = static_cast<int>(std::floor(lo_y));
  return {x0, y0, static_cast<int>(std::ceil(hi_x)) - x0 + 1,
          static_cast<int>(std::ceil(hi_y)) - y0 + 1};
}

cv::Rect StereoRanger::raw_box_to_rectified(Mode mode, double x_min, double y_min, double x_max,
                                            double y_max) const {
  const camera::Rig& rig = impl_->rig;
  const camera::RigCamera& cam =
      rig.camera(mode == Mode::infrared ? rig.infrared.left : rig.visible.left);
  const RangingGeometry& g = geometry(mode);
  return raw_box_on_grid(cam, g.T_ref_left_rect, g.grid, x_min, y_min, x_max, y_max);
}

namespace {

// A box of `from`'s left rectified grid on `to`'s: where the midpoints of its edges fall (the
// left and right ones give the columns, the top and bottom ones the rows), for a target at
// distance_m from `from`'s left camera (0: at infinity, rotation only). The midpoints, not the
// corners: the two grids' frames differ by a small roll, so the bounding box of the corners
// would widen an upright target's box by background (a 5 m person: 62 px instead of 52).
// Empty when a midpoint does not reach `to`'s grid.
cv::Rect box_between(const RangingGeometry& from, const RangingGeometry& to, const cv::Rect& box,
                     double distance_m) {
  const Eigen::Isometry3d T = to.T_ref_left_rect.inverse() * from.T_ref_left_rect;
  auto map = [&](double x, double y, Eigen::Vector2d& q) {
    Eigen::Vector3d ray;
    if (!from.grid.unproject(Eigen::Vector2d(x, y), ray)) return false;
    const Eigen::Vector3d seen = distance_m > 0
                                     ? Eigen::Vector3d(T * (ray.normalized() * distance_m))
                                     : Eigen::Vector3d(T.linear() * ray);
    return to.grid.project(seen, q);
  };
  const double x0 = box.x - 0.5, y0 = box.y - 0.5, x1 = box.br().x - 0.5, y1 = box.br().y - 0.5;
  const double xc = 0.5 * (x0 + x1), yc = 0.5 * (y0 + y1);
  Eigen::Vector2d left, right, top, bottom;
  if (!map(x0, yc, left) || !map(x1, yc, right) || !map(xc, y0, top) || !map(xc, y1, bottom)) {
    return {};
  }
  const int x = static_cast<int>(std::lround(std::min(left.x(), right.x()) + 0.5)),
            y = static_cast<int>(std::lround(std::min(top.y(), bottom.y()) + 0.5));
  return {x, y, static_cast<int>(std::lround(std::max(left.x(), right.x()) + 0.5)) - x,
          static_cast<int>(std::lround(std::max(top.y(), bottom.y()) + 0.5)) - y};
}

}  // namespace

cv::Rect StereoRanger::infrared_box_to_visible(const cv::Rect& box, double distance_m) const {
  return box_between(impl_->infrared_geometry, impl_->visible_geometry, box, distance_m);
}

cv::Rect StereoRanger::visible_box_to_infrared(const cv::Rect& box, double distance_m) const {
  return box_between(impl_->visible_geometry, impl_->infrared_geometry, box, distance_m);
}

RangedTarget StereoRanger::range(const RectifiedFrames& frames, Mode mode, const cv::Rect& box,
                                 const RangerOptions& options) const {
  RangedTarget out;
  out.mode = mode;
  out.box = box;
  // One pair: match inside the box and range, the distance moved to the centre when no shape
  // does it point by point.
  auto range_pair = [&](const cv::Mat& left, const cv::Mat& right, const RangingGeometry& geo,
                        const cv::Rect& pair_box, match::MatchResult& matching) {
    match::MatchOptions mo = options.match;
    mo.min_disparity_px = 0.0;
    mo.max_disparity_px = max_disparity_for(geo, options.min_distance_m);
    matching = match::match_box(left, right, pair_box, mo);
    RangeOptions ro = options.range;
    ro.contour_reach_px = mo.patch_radius;  // the patch that was correlated
    TargetRange r = range_target(geo, pair_box, matching.matches, ro);
    if (options.range.shape.empty()) move_to_centre(r, geo, options.centre_offset_m);
    return r;
  };
  if (mode == Mode::visible) {
    out.range =
        range_pair(frames.visible_left, frames.visible_right, geometry(mode), box, out.matching);
    return out;
  }
  if (mode == Mode::infrared) {
    out.range =
        range_pair(frames.infrared_left, frames.infrared_right, geometry(mode), box, out.matching);
    return out;
  }
  // Fused: both pairs range the target and their independent measurements are combined by
  // their uncertainties. The infrared box is the visible box seen from the infrared camera at
  // the target's distance (the cameras' offset shifts a 5 m target by about 8 infrared px); when
  // the visible pair gives no distance, at infinity first and again at the infrared pair's own.
  const RangingGeometry& ir = geometry(Mode::infrared);
  out.visible = range_pair(frames.visible_left, frames.visible_right, geometry(Mode::visible), box,
                           out.matching);
  if (!frames.infrared_left.empty() && !frames.infrared_right.empty()) {
    const bool seen = out.visible.status == RangeStatus::ok;
    out.infrared_box = visible_box_to_infrared(box, seen ? out.visible.distance_m : 0.0);
    out.infrared = range_pair(frames.infrared_left, frames.infrared_right, ir, out.infrared_box,
                              out.infrared_matching);
    if (!seen && out.infrared.status == RangeStatus::ok) {
      out.infrared_box = visible_box_to_infrared(box, out.infrared.distance_m);
      out.infrared = range_pair(frames.infrared_left, frames.infrared_right, ir, out.infrared_box,
                                out.infrared_matching);
    }
  } else {
    out.infrared.message = "no infrared frames";
  }
  const double shared_sigma = options.range.shape.empty() ? 0.0 : options.range.shape_sigma_m;
  out.range = combine_ranges(out.visible, out.infrared, geometry(Mode::visible), shared_sigma);
  return out;
}

}  // namespace thermovis::range
