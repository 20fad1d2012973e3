#pragma once
// thermovis-rectify-fuse: raw visible + infrared stereo frames -> both bands on the visible pair's
// rectified grid (composed maps computed once, fixed-point remap), infrared gain control,
// visible contrast enhancement and fusion (left eye; both with fuse_right_eye). Publishes the
// rectified visible (BGR8), rectified infrared (MONO16 raw counts) and fused (BGR8) stereo frames,
// each written in place into a loaned sample. Only the newest capture is processed: older ones
// waiting are dropped and counted.
#include <array>
#include <chrono>
#include <memory>

#include "thermovis/enhance/infrared_agc.hpp"
#include "thermovis/enhance/visible_contrast.hpp"
#include "thermovis/fpga/remap.hpp"
#include "thermovis/frames.h"
#include "thermovis/fuse/fusion.hpp"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/node/pipeline_grid.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::rectify_fuse {

struct RectifyFuseConfig {
  node::GridOptions grid;
  // Fusion of the luma, with the visible contrast enhancement (CLAHE) done on the same luma.
  fuse::FusionOptions fusion{
      fuse::FusionMethod::fast, fuse::ColourMode::luminance, {}, enhance::VisibleContrastParams{}};
  // The display needs the left eye fused; only matching on the fused band needs the right one.
  bool fuse_right_eye = false;
  // The visible pair rectified on a second thread while this one rectifies the infrared: both
  // pairs out sooner when a core is free; on the 2-core reference machine, whose cores the
  // pipeline keeps busy, it delayed the infrared pair (rectify-fuse stage p50 12-14 ms instead
  // of 5.2) without more captures answered, so it is off by default.
  bool parallel_bands = false;
  enhance::AgcParams agc;
  std::chrono::nanoseconds deadline{20'000'000};
};

struct RectifyFuseStats {
  std::uint64_t processed = 0;
  std::uint64_t dropped = 0;   // captures superseded before they were processed
  std::uint64_t bad = 0;       // frames rejected (bad header, size mismatch)
  std::uint64_t repeated = 0;  // captures received again or out of order, skipped
};

class RectifyFuseNode {
 public:
  RectifyFuseNode(transport::Participant& participant, const camera::Rig& rig,
                  const RectifyFuseConfig& config, const std::string& service_name);
  void run();  // until node::stop_requested()
  RectifyFuseStats stats() const { return stats_; }
  cv::Size grid_size() const { return grid_size_; }

 private:
  void process(const VisibleStereoFrame& visible, const InfraredStereoFrame& infrared);

  RectifyFuseConfig config_;
  cv::Size grid_size_;
  std::array<std::unique_ptr<fpga::FastRemapper>, 2> visible_maps_;   // left, right eye
  std::array<std::unique_ptr<fpga::FastRemapper>, 2> infrared_maps_;  // onto the visible grid
  std::array<enhance::InfraredAgc, 2> agc_;
  transport::Reader<VisibleStereoFrame> visible_in_;
  transport::Reader<InfraredStereoFrame> infrared_in_;
  transport::Writer<GridStereoFrame> rectified_visible_out_;
  transport::Writer<GridStereoFrame> rectified_infrared_out_;
  transport::Writer<GridStereoFrame> fused_out_;
  node::HealthReporter health_;
  RectifyFuseStats stats_;
  node::FrameOrder order_;  // of the visible frames taken
};

}  // namespace thermovis::rectify_fuse
