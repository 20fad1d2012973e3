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
  out.infrared_raw_left = agc_of(raw.infrared_left, rig.camera(rig.infrared.left), "infrared left");
  out.infrared_raw_right =
      agc_of(raw.infrared_right, rig.camera(rig.infrared.right), "infrared right");
  out.infrared_left = remap_with(out.infrared_raw_left, impl_->infrared.left_map);
  if (raw.infrared_left.type() == CV_16UC1) {
    out.infrared_counts_left = remap_with(raw.infrared_left, impl_->infrared.left_map);
  }
  out.infrared_right = remap_with(out.infrared_raw_right, impl_->infrared.right_map);
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

// A box of `from`'s left rectified grid on `to`'s (rays at infinity), the bounding box of its
// border's rays; empty when none of them reaches `to`'s grid.
cv::Rect box_between(const RangingGeometry& from, const RangingGeometry& to, const cv::Rect& box) {
  const Eigen::Matrix3d R =
      to.T_ref_left_rect.rotation().transpose() * from.T_ref_left_rect.rotation();
  double lo_x = 1e30, lo_y = 1e30, hi_x = -1e30, hi_y = -1e30;
  const int steps = 8;
  for (int i = 0; i <= steps; ++i) {
    const double t = static_cast<double>(i) / steps;
    const double x0 = box.x - 0.5, y0 = box.y - 0.5, x1 = box.br().x - 0.5, y1 = box.br().y - 0.5;
    for (const Eigen::Vector2d& p :
         {Eigen::Vector2d(x0 + t * (x1 - x0), y0), Eigen::Vector2d(x0 + t * (x1 - x0), y1),
          Eigen::Vector2d(x0, y0 + t * (y1 - y0)), Eigen::Vector2d(x1, y0 + t * (y1 - y0))}) {
      Eigen::Vector3d ray;
      Eigen::Vector2d q;
      if (!from.grid.unproject(p, ray) || !to.grid.project(R * ray, q)) continue;
      lo_x = std::min(lo_x, q.x());
      lo_y = std::min(lo_y, q.y());
      hi_x = std::max(hi_x, q.x());
      hi_y = std::max(hi_y, q.y());
    }
  }
  if (lo_x > hi_x) return {};
  const int x = static_cast<int>(std::lround(lo_x + 0.5)),
            y = static_cast<int>(std::lround(lo_y + 0.5));
  return {x, y, static_cast<int>(std::lround(hi_x + 0.5)) - x,
          static_cast<int>(std::lround(hi_y + 0.5)) - y};
}

}  // namespace

cv::Rect StereoRanger::infrared_box_to_visible(const cv::Rect& box) const {
  return box_between(impl_->infrared_geometry, impl_->visible_geometry, box);
}

cv::Rect StereoRanger::visible_box_to_infrared(const cv::Rect& box) const {
  return box_between(impl_->visible_geometry, impl_->infrared_geometry, box);
}

RangedTarget StereoRanger::range(const RectifiedFrames& frames, Mode mode, const cv::Rect& box,
                                 const RangerOptions& options) const {
  RangedTarget out;
  out.mode = mode;
  out.box = box;
  const RangingGeometry& g = geometry(mode);
  match::MatchOptions mo = options.match;
  mo.min_disparity_px = 0.0;
  mo.max_disparity_px = max_disparity_for(g, options.min_distance_m);
  auto run = [&](const cv::Mat& left, const cv::Mat& right, const RangingGeometry& geo) {
    out.matching = match::match_box(left, right, box, mo);
    out.range = range_target(geo, box, out.matching.matches, options.range);
  };
  if (mode == Mode::visible) {
    run(frames.visible_left, frames.visible_right, g);
  } else if (mode == Mode::infrared) {
    run(frames.infrared_left, frames.infrared_right, g);
  } else {
    // Registration distance: the target's own, measured on the visible pair first, else on the
    // infrared pair (at night, or a box with too little visible texture); infinity when neither
    // ranges it (the infrared content then keeps the infrared cameras' offset as disparity).
    run(frames.visible_left, frames.visible_right, g);
    double registration = out.range.status == RangeStatus::ok ? out.range.distance_m : 0.0;
    if (registration == 0.0 && !frames.infrared_left.empty()) {
      const RangingGeometry& ir = geometry(Mode::infrared);
      const cv::Rect ir_box = visible_box_to_infrared(box);
      match::MatchOptions ir_mo = mo;
      ir_mo.max_disparity_px = max_disparity_for(ir, options.min_distance_m);
      const TargetRange ir_range = range_target(
          ir, ir_box,
          match::match_box(frames.infrared_left, frames.infrared_right, ir_box, ir_mo).matches,
          options.range);
      if (ir_range.status == RangeStatus::ok) registration = ir_range.distance_m;
    }
    out.registration_distance_m = registration;
    const camera::Rig& rig = impl_->rig;
    const cv::Rect image(0, 0, frames.visible_left.cols, frames.visible_left.rows);
    const int pad = mo.patch_radius + 16;
    const int dmax = static_cast<int>(std::ceil(mo.max_disparity_px));
    // One band for both eyes (the left box and the right search range): fusion filters
    // (box means, guided filters) then see the same extent in both, so their border effects do
    // not differ between the eyes.
    const cv::Rect band = cv::Rect(box.x - dmax - pad, box.y - pad, box.width + dmax + 2 * pad,
                                   box.height + 2 * pad) &
                          image;
    const cv::Rect left_roi = band, right_roi = band;
    if (left_roi.empty() || right_roi.empty()) {
      out.range = range_target(g, box, {}, options.range);  // the status names the box problem
      return out;
    }
    auto fused_eye = [&](const cv::Mat& visible, const cv::Mat& infrared_agc,
                         const std::string& ir_name, const Eigen::Isometry3d& T_ref_rect,
                         const cv::Rect& roi) {
      const cv::Mat map =
          rectify::build_map(rig.camera(ir_name), T_ref_rect, g.grid, registration, roi);
      const cv::Mat ir = remap_with(infrared_agc, map);
      const cv::Mat vis = visible(roi).clone();
      // An equal blend, the same in both eyes. The display's two-scale fusion weighs each pixel
      // by its own eye's saliency, and noise made the eyes mix one surface differently (fused
      // points scattered 0.3-0.5 px in disparity, visible ones 0.05-0.12 px).
      cv::Mat fused_roi;
      cv::addWeighted(vis, 0.5, ir, 0.5, 0.0, fused_roi);
      cv::Mat fused = visible.clone();
      fused_roi.copyTo(fused(roi));
      return fused;
    };
    const cv::Mat fused_left =
        fused_eye(frames.visible_left, frames.infrared_raw_left, rig.infrared.left,
                  impl_->visible.geometry.T_ref_left_rect, left_roi);
    const cv::Mat fused_right =
        fused_eye(frames.visible_right, frames.infrared_raw_right, rig.infrared.right,
                  impl_->visible.geometry.T_ref_right_rect, right_roi);
    run(fused_left, fused_right, g);
  }
  if (options.range.shape.empty()) move_to_centre(out.range, g, options.centre_offset_m);
  return out;
}

}  // namespace thermovis::range
