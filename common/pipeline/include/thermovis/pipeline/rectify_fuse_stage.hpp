#pragma once
// Stage 1: raw captures -> both bands on the pipeline grid, and the fused images.
//
// One composed map per camera (distortion correction + rectification, and for the infrared
// cameras the registration onto their eye's visible frame), computed once and applied in fixed
// point (fpga/remap.hpp: bit-exact with the FPGA model), from the raw image or, for a visible
// camera with twice the grid's px per rad or more, from it binned to about the grid's
// (RectifyFuseOptions::bin_visible). Pixel formats:
//  - visible: raw CV_8UC3 (BGR) or CV_8UC1 of the visible camera's size -> CV_8UC1 on the grid
//    (RectifyFuseOptions::visible_mono, the default), else the raw type;
//  - infrared: raw CV_16UC1 counts (or CV_8UC1) of the infrared camera's size -> the same type on
//    the grid: the counts are kept (detection thresholds on temperature, matching stretches each
//    box's surroundings itself);
//  - fused: the visible image's type. The infrared goes through the thermal cameras' gain control
//    (enhance/infrared_agc.hpp, one per eye: its mapping is smoothed over frames), then the
//    fusion (fuse/fusion.hpp) with the visible contrast enhancement on the same luma.
// The infrared is registered onto the visible at the geometry's registration distance, infinity
// by default, which the infrared pair's geometry (PipelineGeometry::infrared) describes exactly;
// at a finite distance the fused images align there and infrared ranges off it are biased.
#include <array>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "thermovis/camera/rig.hpp"
#include "thermovis/enhance/infrared_agc.hpp"
#include "thermovis/fpga/remap.hpp"
#include "thermovis/fuse/fusion.hpp"
#include "thermovis/pipeline/geometry.hpp"

namespace thermovis::pipeline {

struct RectifyFuseOptions {
  // Fusion of the luma, with the visible contrast enhancement (CLAHE) done on the same luma.
  fuse::FusionOptions fusion{
      fuse::FusionMethod::fast, fuse::ColourMode::luminance, {}, enhance::VisibleContrastParams{}};
  enhance::AgcParams agc;
  // Bin the visible cameras' raw images to about the grid's px per rad before the remap when
  // they have twice its or more (2 x 2 on the pipeline grid).
  bool bin_visible = true;
  // The rectified visible pair in grey (CV_8UC1, the luma of OpenCV's BGR2GRAY taken from the
  // binned raw image before the remap) instead of the raw image's colour: every stage of the
  // pipeline works on the luma, and one byte per pixel costs a third of the remap's writes. The
  // fusion keeps its colour (fusion_visible).
  bool visible_mono = true;
};

class RectifyFuseStage {
 public:
  // Computes the maps (a second or two on the full grid). Throws std::invalid_argument for a rig
  // without the geometry's cameras.
  RectifyFuseStage(const camera::Rig& rig, const PipelineGeometry& geometry,
                   const RectifyFuseOptions& options = {});
  ~RectifyFuseStage();

  const PipelineGeometry& geometry() const { return geometry_; }
  cv::Size grid_size() const { return geometry_.grid_size(); }

  // `out` is reused when it has the band's image size (PipelineGeometry::image_size: the grid,
  // the infrared's reduced by its reduction) and the input's type (a loaned sample's buffer).
  // Throws std::invalid_argument naming the camera for a wrong size or type.
  // The visible image is grey with RectifyFuseOptions::visible_mono, else the raw image's type.
  void rectify_visible(Eye eye, const cv::Mat& raw, cv::Mat& out) const;
  bool visible_mono() const { return options_.visible_mono; }
  // The visible image the fusion takes: `rectified` (rectify_visible's), or under visible_mono
  // `raw` rectified again in its own colour (into a buffer of the stage's, valid until the next
  // call for the eye).
  const cv::Mat& fusion_visible(Eye eye, const cv::Mat& rectified, const cv::Mat& raw);
  void rectify_infrared(Eye eye, const cv::Mat& raw, cv::Mat& out) const;
  // The gain-controlled (CV_8UC1) image of rectified infrared counts; updates the eye's mapping.
  cv::Mat gain_control(Eye eye, const cv::Mat& infrared);
  // Gain control, then fusion with the rectified visible image of the same eye, into `fused`
  // (a reduced infrared image brought onto the grid first).
  void fuse(Eye eye, const cv::Mat& infrared, const cv::Mat& visible, cv::Mat& fused);

 private:
  void rectify_visible_as(Eye eye, const cv::Mat& raw, cv::Mat& out, bool mono) const;

  struct Eyes {
    std::unique_ptr<fpga::FastRemapper> left, right;
    const fpga::FastRemapper& operator[](Eye eye) const {
      return eye == Eye::left ? *left : *right;
    }
  };
  PipelineGeometry geometry_;
  RectifyFuseOptions options_;
  Eyes visible_, infrared_;
  int visible_bin_ = 1;                            // raw visible px per binned px, each way
  std::vector<cv::Size> visible_raw_;              // the visible cameras' sizes, left, right
  mutable std::array<cv::Mat, 2> binned_visible_;  // per eye (the eyes may run on two threads)
  mutable std::array<cv::Mat, 2> grey_visible_;    // per eye, the raw image's luma
  std::array<cv::Mat, 2> colour_visible_;          // per eye, fusion_visible's under visible_mono
  std::array<enhance::InfraredAgc, 2> agc_;
};

}  // namespace thermovis::pipeline
