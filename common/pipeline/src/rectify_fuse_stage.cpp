#include "thermovis/pipeline/rectify_fuse_stage.hpp"

#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "thermovis/rectify/stereo_geometry.hpp"

namespace thermovis::pipeline {
namespace {

std::unique_ptr<fpga::FastRemapper> remapper(const camera::Rig& rig, const std::string& camera,
                                             const Eigen::Isometry3d& T_ref_rect,
                                             const camera::RectifiedCamera& grid,
                                             double distance_m) {
  const camera::RigCamera& cam = rig.camera(camera);
  return std::make_unique<fpga::FastRemapper>(fpga::FixedPointMap::from_float(
      rectify::build_map(cam, T_ref_rect, grid, distance_m), cam.model->image_size()));
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
  visible_.left = remapper(rig, v.left_camera, v.T_ref_left_rect, grid, 0.0);
  visible_.right = remapper(rig, v.right_camera, v.T_ref_right_rect, grid, 0.0);
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
  remap_into(visible_[eye], raw, out,
             eye == Eye::left ? geometry_.visible.left_camera : geometry_.visible.right_camera);
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
