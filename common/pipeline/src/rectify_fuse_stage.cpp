#include "thermovis/pipeline/rectify_fuse_stage.hpp"

#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "thermovis/rectify/stereo_geometry.hpp"

namespace thermovis::pipeline {
namespace {

// The map of a camera onto `grid`, from its raw image binned by `bin` (rectify::bin_map).
std::unique_ptr<fpga::FastRemapper> remapper(const camera::Rig& rig, const std::string& camera,
                                             const Eigen::Isometry3d& T_ref_rect,
                                             const camera::RectifiedCamera& grid, double distance_m,
                                             int bin = 1) {
  const camera::RigCamera& cam = rig.camera(camera);
  cv::Mat map = rectify::build_map(cam, T_ref_rect, grid, distance_m);
  const cv::Size raw = cam.model->image_size();
  rectify::bin_map(map, bin);
  return std::make_unique<fpga::FastRemapper>(
      fpga::FixedPointMap::from_float(map, cv::Size(raw.width / bin, raw.height / bin)));
}

void remap_into(const fpga::FastRemapper& map, const cv::Mat& raw, cv::Mat& out,
                const std::string& camera) {
  try {
    map.remap(raw, out);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(camera + ": " + e.what());
  }
}

}  // namespace

RectifyFuseStage::RectifyFuseStage(const camera::Rig& rig, const PipelineGeometry& geometry,
                                   const RectifyFuseOptions& options)
    : geometry_(geometry),
      options_(options),
      agc_{enhance::InfraredAgc(options.agc), enhance::InfraredAgc(options.agc)} {
  const camera::RectifiedCamera grid(geometry.grid);
  const PairGeometry& v = geometry.visible;
  // A visible camera with twice the grid's px per rad or more is binned to about the grid's
  // before the remap: bilinear sampling at half the camera's resolution reads 4 of every 16
  // raw pixels and aliases their texture into the grid (the pipeline grid, 417 px/rad, of the
  // 835 px/rad cameras).
  visible_bin_ =
      options_.bin_visible
          ? grid_reduction(rectify::default_pair_grid(rig, rig.visible, geometry.grid.projection),
                           geometry.grid.f)
          : 1;
  for (const std::string& name : {v.left_camera, v.right_camera})
    visible_raw_.push_back(rig.camera(name).model->image_size());
  visible_.left = remapper(rig, v.left_camera, v.T_ref_left_rect, grid, 0.0, visible_bin_);
  visible_.right = remapper(rig, v.right_camera, v.T_ref_right_rect, grid, 0.0, visible_bin_);
  // Each infrared camera onto its eye's visible frame, at the registration distance (its
  // centre is not the eye's: at infinity only the rotation matters), on the grid reduced by the
  // infrared reduction.
  const double d = geometry.registration_distance_m;
  const camera::RectifiedCamera infrared_grid(geometry.image_grid(Band::infrared));
  infrared_.left =
      remapper(rig, geometry.infrared.left_camera, v.T_ref_left_rect, infrared_grid, d);
  infrared_.right =
      remapper(rig, geometry.infrared.right_camera, v.T_ref_right_rect, infrared_grid, d);
}

RectifyFuseStage::~RectifyFuseStage() = default;

void RectifyFuseStage::rectify_visible(Eye eye, const cv::Mat& raw, cv::Mat& out) const {
  rectify_visible_as(eye, raw, out, options_.visible_mono);
}

const cv::Mat& RectifyFuseStage::fusion_visible(Eye eye, const cv::Mat& rectified,
                                                const cv::Mat& raw) {
  if (!options_.visible_mono) return rectified;
  cv::Mat& colour = colour_visible_[eye == Eye::left ? 0 : 1];
  rectify_visible_as(eye, raw, colour, false);
  return colour;
}

void RectifyFuseStage::rectify_visible_as(Eye eye, const cv::Mat& raw, cv::Mat& out,
                                          bool mono) const {
  const std::size_t i = eye == Eye::left ? 0 : 1;
  const std::string& camera =
      eye == Eye::left ? geometry_.visible.left_camera : geometry_.visible.right_camera;
  const bool to_grey = mono && raw.type() == CV_8UC3;
  if (visible_bin_ == 1 && !to_grey) return remap_into(visible_[eye], raw, out, camera);
  // The remapper's own checks, on the raw image (it sees the grey or binned one).
  const cv::Size size = visible_raw_[i];
  if (raw.empty()) throw std::invalid_argument(camera + ": remap: the input image is empty");
  if (raw.size() != size) {
    throw std::invalid_argument(camera + ": remap: input image is " + std::to_string(raw.cols) +
                                "x" + std::to_string(raw.rows) + " but the table was made for a " +
                                std::to_string(size.width) + "x" + std::to_string(size.height) +
                                " camera");
  }
  // Binned first (the luma of the binned colour: a quarter of the conversion's pixels).
  cv::Mat source = raw;
  if (visible_bin_ > 1) {
    reduce_image(source, visible_bin_, binned_visible_[i]);
    source = binned_visible_[i];
  }
  if (to_grey) {
    cv::cvtColor(source, grey_visible_[i], cv::COLOR_BGR2GRAY);
    source = grey_visible_[i];
  }
  remap_into(visible_[eye], source, out, camera);
}

void RectifyFuseStage::rectify_infrared(Eye eye, const cv::Mat& raw, cv::Mat& out) const {
  remap_into(infrared_[eye], raw, out,
             eye == Eye::left ? geometry_.infrared.left_camera : geometry_.infrared.right_camera);
}

cv::Mat RectifyFuseStage::gain_control(Eye eye, const cv::Mat& infrared) {
  return agc_[eye == Eye::left ? 0 : 1].process(infrared);
}

void RectifyFuseStage::fuse(Eye eye, const cv::Mat& infrared, const cv::Mat& visible,
                            cv::Mat& fused) {
  cv::Mat grey = gain_control(eye, infrared);
  if (grey.size() != visible.size() && geometry_.infrared_reduction > 1 &&
      grey.size() == geometry_.image_size(Band::infrared)) {
    // The reduced infrared onto the grid (pixel centres as grid_coordinate: cv::resize's), the
    // last incomplete block's columns and rows from the edge.
    const int k = geometry_.infrared_reduction;
    cv::Mat up;
    cv::resize(grey, up, cv::Size(grey.cols * k, grey.rows * k), 0, 0, cv::INTER_LINEAR);
    cv::copyMakeBorder(up, grey, 0, visible.rows - up.rows, 0, visible.cols - up.cols,
                       cv::BORDER_REPLICATE);
  }
  fuse::fuse(grey, visible, fused, options_.fusion);
}

}  // namespace thermovis::pipeline
