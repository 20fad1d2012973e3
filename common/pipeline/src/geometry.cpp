#include "thermovis/pipeline/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "thermovis/rectify/stereo_geometry.hpp"
#include "thermovis/util/enum_names.hpp"

namespace thermovis::pipeline {

namespace {

constexpr util::EnumName<Band> kBandNames[] = {
    {Band::visible, "visible"}, {Band::infrared, "infrared"}, {Band::fused, "fused"}};

}  // namespace

std::string band_name(Band band) { return util::name_of(kBandNames, band, "unknown"); }

range::RangingGeometry PipelineGeometry::ranging(Band band) const {
  const PairGeometry& pair = band == Band::infrared ? infrared : visible;
  range::RangingGeometry g{camera::RectifiedCamera(grid), pair.baseline_m, pair.T_ref_left_rect};
  if (band == Band::infrared) {
    g.right_centre_m = pair.T_ref_left_rect.inverse() * pair.T_ref_right_rect.translation();
  }
  return g;
}

camera::RectifiedIntrinsics PipelineGeometry::image_grid(Band band) const {
  return reduce_grid(grid, reduction(band));
}

cv::Size PipelineGeometry::image_size(Band band) const {
  const camera::RectifiedIntrinsics g = image_grid(band);
  return {g.width, g.height};
}

camera::RectifiedIntrinsics reduce_grid(const camera::RectifiedIntrinsics& grid, int k) {
  if (k < 1) throw std::invalid_argument("reduce_grid: k must be >= 1");
  if (k == 1) return grid;
  camera::RectifiedIntrinsics out = grid;
  out.width = grid.width / k;
  out.height = grid.height / k;
  out.f = grid.f / k;
  out.cx = (grid.cx + 0.5) / k - 0.5;
  out.cy = (grid.cy + 0.5) / k - 0.5;
  return out;
}

void reduce_image(const cv::Mat& image, int k, cv::Mat& out) {
  const cv::Size size(image.cols / k, image.rows / k);
  cv::resize(image(cv::Rect(0, 0, size.width * k, size.height * k)), out, size, 0, 0,
             cv::INTER_AREA);
}

cv::Rect reduce_box(const cv::Rect& box, int k) {
  if (k == 1 || box.empty()) return box;
  const auto floor_div = [k](int v) { return v >= 0 ? v / k : -((-v + k - 1) / k); };
  const int x0 = floor_div(box.x), y0 = floor_div(box.y);
  const int x1 = -floor_div(-(box.x + box.width)), y1 = -floor_div(-(box.y + box.height));
  return {x0, y0, x1 - x0, y1 - y0};
}

namespace {

// An infrared reduction no stage can work with: std::invalid_argument, `what` first.
void check_infrared_reduction(const camera::RectifiedIntrinsics& grid, int k,
                              const std::string& what) {
  if (k < 1 || k > 8 || grid.width / k < 16 || grid.height / k < 16) {
    throw std::invalid_argument(what + "infrared reduction " + std::to_string(k) +
                                " is outside 1-8 or leaves an image under 16 px");
  }
}

class Digest {
 public:
  void add(const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) hash_ = (hash_ ^ bytes[i]) * 16777619u;
  }
  void add(double v) { add(&v, sizeof v); }
  void add(int v) { add(&v, sizeof v); }
  void add(const std::string& s) {
    add(s.data(), s.size());
    add(0);  // a separator: ("ab", "c") and ("a", "bc") differ
  }
  void add(const Eigen::Isometry3d& T) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) add(T.matrix()(r, c));
  }
  std::uint32_t value() const { return hash_ == 0 ? 1u : hash_; }

 private:
  std::uint32_t hash_ = 2166136261u;
};

PairGeometry pair_of(const rectify::StereoGeometry& g) {
  return {g.left, g.right, g.T_ref_left_rect, g.T_ref_right_rect, g.baseline_m};
}

void check_finite(const Eigen::Isometry3d& T, const std::string& what) {
  if (!T.matrix().allFinite()) throw std::invalid_argument(what + ": non-finite pose");
  const Eigen::Matrix3d R = T.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 ||
      R.determinant() < 0) {
    throw std::invalid_argument(what + ": rotation is not a rotation");
  }
}

}  // namespace

std::uint32_t PipelineGeometry::id() const {
  Digest d;
  d.add(grid.width);
  d.add(grid.height);
  d.add(grid.f);
  d.add(grid.cx);
  d.add(grid.cy);
  d.add(static_cast<int>(grid.projection));
  for (const PairGeometry* pair : {&visible, &infrared}) {
    d.add(pair->left_camera);
    d.add(pair->right_camera);
    d.add(pair->T_ref_left_rect);
    d.add(pair->T_ref_right_rect);
    d.add(pair->baseline_m);
  }
  d.add(T_ref_reporting);
  d.add(registration_distance_m);
  // Added only when the infrared is reduced, so that a geometry on one grid keeps the digest it
  // had before infrared images could be reduced (recordings name it).
  if (infrared_reduction != 1) d.add(infrared_reduction);
  return d.value();
}

int grid_reduction(const camera::RectifiedIntrinsics& grid, double px_per_rad) {
  if (px_per_rad < 0 || !std::isfinite(px_per_rad)) {
    throw std::invalid_argument("reduced_px_per_rad must be >= 0");
  }
  if (px_per_rad == 0) return 1;
  return std::max(1, static_cast<int>(std::lround(grid.f / px_per_rad)));
}

PipelineGeometry make_geometry(const camera::Rig& rig, const GridOptions& options) {
  PipelineGeometry out;
  out.grid = camera::scaled(rectify::default_pair_grid(rig, rig.visible, options.projection),
                            options.scale);
  const rectify::StereoGeometry visible = rectify::make_stereo_geometry(rig, rig.visible, out.grid);
  out.visible = pair_of(visible);
  // The infrared cameras registered at infinity onto their eyes' visible rectified frames: the
  // same rotation, the infrared cameras' own centres.
  const Eigen::Vector3d left = rig.camera(rig.infrared.left).T_ref_cam.translation();
  const Eigen::Vector3d right = rig.camera(rig.infrared.right).T_ref_cam.translation();
  out.infrared = out.visible;
  out.infrared.left_camera = rig.infrared.left;
  out.infrared.right_camera = rig.infrared.right;
  out.infrared.T_ref_left_rect.translation() = left;
  out.infrared.T_ref_right_rect.translation() = right;
  out.infrared.baseline_m = (out.visible.T_ref_left_rect.linear().transpose() * (right - left)).x();
  if (!(out.infrared.baseline_m > 0)) {
    throw std::invalid_argument("rig: the right infrared camera is not right of the left one " +
                                std::string("along the visible baseline"));
  }
  out.T_ref_reporting = rig.camera(rig.visible.left).T_ref_cam;
  out.registration_distance_m = options.registration_distance_m;
  if (options.infrared_reduction < 0) {
    throw std::invalid_argument("infrared_reduction must be >= 0 (0: from the infrared cameras)");
  }
  out.infrared_reduction =
      options.infrared_reduction > 0
          ? options.infrared_reduction
          : grid_reduction(out.grid,
                           rectify::default_pair_grid(rig, rig.infrared, options.projection).f);
  check_infrared_reduction(out.grid, out.infrared_reduction, "");
  return out;
}

void validate(const PipelineGeometry& g, cv::Size max_size) {
  const auto& i = g.grid;
  if (i.width <= 0 || i.height <= 0 || i.width > max_size.width || i.height > max_size.height) {
    throw std::invalid_argument("geometry: grid " + std::to_string(i.width) + "x" +
                                std::to_string(i.height) + " is empty or larger than " +
                                std::to_string(max_size.width) + "x" +
                                std::to_string(max_size.height));
  }
  if (!std::isfinite(i.f) || !(i.f > 0)) throw std::invalid_argument("geometry: grid f is not > 0");
  if (!std::isfinite(i.cx) || !std::isfinite(i.cy)) {
    throw std::invalid_argument("geometry: grid centre is not finite");
  }
  for (const auto& [pair, name] :
       {std::pair{&g.visible, "visible"}, std::pair{&g.infrared, "infrared"}}) {
    const std::string what = std::string("geometry: ") + name + " pair";
    check_finite(pair->T_ref_left_rect, what + " left frame");
    check_finite(pair->T_ref_right_rect, what + " right frame");
    if (!std::isfinite(pair->baseline_m) || !(pair->baseline_m > 0)) {
      throw std::invalid_argument(what + ": baseline is not > 0");
    }
    if ((pair->T_ref_left_rect.linear() - g.visible.T_ref_left_rect.linear())
                .cwiseAbs()
                .maxCoeff() > 1e-9 ||
        (pair->T_ref_right_rect.linear() - g.visible.T_ref_left_rect.linear())
                .cwiseAbs()
                .maxCoeff() > 1e-9) {
      throw std::invalid_argument(what + ": frames do not share the grid's rotation");
    }
  }
  check_finite(g.T_ref_reporting, "geometry: reporting frame");
  check_infrared_reduction(i, g.infrared_reduction, "geometry: ");
  if (!std::isfinite(g.registration_distance_m)) {
    throw std::invalid_argument("geometry: registration distance is not finite");
  }
}

double max_disparity(const PipelineGeometry& geometry, double min_distance_m) {
  return std::max(range::max_disparity_for(geometry.ranging(Band::visible), min_distance_m),
                  range::max_disparity_for(geometry.ranging(Band::infrared), min_distance_m));
}

cv::Rect raw_box_on_grid(const PipelineGeometry& geometry, const camera::Rig& rig, Band band,
                         double x_min, double y_min, double x_max, double y_max) {
  const PairGeometry& pair = band == Band::infrared ? geometry.infrared : geometry.visible;
  return rectify::raw_box_on_grid(rig.camera(pair.left_camera), pair.T_ref_left_rect,
                                  camera::RectifiedCamera(geometry.grid), x_min, y_min, x_max,
                                  y_max);
}

cv::Rect points_box_on_grid(const PipelineGeometry& geometry, Band band,
                            const std::vector<Eigen::Vector3d>& points_m) {
  const PairGeometry& pair = band == Band::infrared ? geometry.infrared : geometry.visible;
  const Eigen::Isometry3d T_rect_reporting =
      pair.T_ref_left_rect.inverse() * geometry.T_ref_reporting;
  std::vector<Eigen::Vector3d> points_rect;
  points_rect.reserve(points_m.size());
  for (const Eigen::Vector3d& p : points_m) points_rect.push_back(T_rect_reporting * p);
  return rectify::rays_box_on_grid(camera::RectifiedCamera(geometry.grid), points_rect) &
         cv::Rect(0, 0, geometry.grid.width, geometry.grid.height);
}

}  // namespace thermovis::pipeline
