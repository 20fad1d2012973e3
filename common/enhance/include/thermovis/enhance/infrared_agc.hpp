#pragma once
// Infrared adaptive gain control (AGC): raw detector counts (14- or 16-bit, CV_16UC1) or 8-bit
// infrared (CV_8UC1) to 8-bit display values by plateau histogram equalisation, the usual thermal
// camera method:
//  - histogram of the frame's counts (one bin per count);
//  - each bin clipped at the plateau = plateau_ratio x (pixel count / occupied bins), so large
//    uniform areas (sky, road) do not take all the grey levels, while low plateaus tend to a
//    linear stretch of the occupied range;
//  - the clipped histogram's cumulative sum over the occupied range, ignoring the
//    tail_fraction darkest and brightest pixels, scaled to 0..255, is the mapping;
//  - for video, the mapping is smoothed over time: lut = (1 - temporal_alpha) lut_prev +
//    temporal_alpha lut_frame, so a hot object entering the view does not make the frame flicker.
// 8-bit input goes through the same path with 256 bins.
#include <vector>

#include <opencv2/core/mat.hpp>

namespace thermovis::enhance {

struct AgcParams {
  double plateau_ratio = 4.0;    // bin clip level, in units of the mean occupied-bin count
  double tail_fraction = 0.001;  // fraction of pixels ignored at each end of the histogram
  double temporal_alpha = 0.2;   // weight of the new frame's mapping (1 = no smoothing)
};

class InfraredAgc {
 public:
  explicit InfraredAgc(AgcParams params = {});

  // Maps one frame (CV_16UC1 counts or CV_8UC1) to CV_8UC1, updating the temporal state.
  // Throws std::invalid_argument for empty input or another pixel type; changing the input
  // depth between frames restarts the smoothing.
  cv::Mat process(const cv::Mat& raw);

  // Forget the previous mapping (e.g. after a scene cut or a non-uniformity correction).
  void reset();

  const AgcParams& params() const { return params_; }

 private:
  AgcParams params_;
  std::vector<float> lut_;  // smoothed mapping, one entry per input count
};

}  // namespace thermovis::enhance
