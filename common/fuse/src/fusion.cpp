#include "thermovis/fuse/fusion.hpp"

#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "thermovis/enhance/visible_contrast.hpp"
#include "thermovis/util/enum_names.hpp"

namespace thermovis::fuse {
namespace {

std::string describe(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " " + cv::typeToString(m.type());
}

void validate(const cv::Mat& m, const char* what) {
  if (m.empty()) throw std::invalid_argument(std::string(what) + " image is empty");
  const int depth = m.depth();
  if (depth != CV_8U && depth != CV_32F && depth != CV_64F) {
    throw std::invalid_argument(std::string(what) + " image must be 8-bit or float, got " +
                                describe(m));
  }
  if (m.channels() != 1 && m.channels() != 3) {
    throw std::invalid_argument(std::string(what) + " image must have 1 or 3 channels, got " +
                                describe(m));
  }
  if (depth != CV_8U && !cv::checkRange(m, true)) {
    throw std::invalid_argument(std::string(what) + " image holds NaN or infinite values");
  }
}

// An image as 8-bit (float intensities in [0,1] scaled, rounded and clipped).
cv::Mat to_u8(const cv::Mat& m) {
  if (m.depth() == CV_8U) return m;
  cv::Mat out;
  m.convertTo(out, CV_8U, 255.0);
  return out;
}

// Plane k as CV_64F in [0,1]: MATLAB's double(uint8)/255, or the float values themselves.
cv::Mat plane_unit(const cv::Mat& m, int k) {
  cv::Mat plane;
  if (m.channels() == 1)
    plane = m;
  else
    cv::extractChannel(m, plane, k);
  cv::Mat out;
  if (m.depth() == CV_8U) {
    plane.convertTo(out, CV_64F);
    out /= 255.0;
  } else {
    plane.convertTo(out, CV_64F);
  }
  return out;
}

// im2uint8: clip to [0,1], x 255, round half away from zero.
cv::Mat im2uint8(const cv::Mat& unit) {
  cv::Mat out(unit.size(), CV_8UC1);
  for (int r = 0; r < unit.rows; ++r) {
    const auto* s = unit.ptr<double>(r);
    auto* d = out.ptr<uchar>(r);
    for (int c = 0; c < unit.cols; ++c) {
      d[c] = static_cast<uchar>(std::floor(std::clamp(s[c], 0.0, 1.0) * 255.0 + 0.5));
    }
  }
  return out;
}

cv::Mat gray_u8(const cv::Mat& m) {
  const cv::Mat u8 = to_u8(m);
  if (u8.channels() == 1) return u8;
  cv::Mat g;
  cv::cvtColor(u8, g, cv::COLOR_BGR2GRAY);
  return g;
}

cv::Mat fuse_plane_vsmwls(const cv::Mat& ir, const cv::Mat& vis, FusionMethod method) {
  if (method == FusionMethod::vsmwls) return vsmwls_fuse(ir, vis, VsmWlsParams{});
  return vsmwls_fuse(vis, ir, VsmWlsParams::paper());
}

void fuse_per_channel(const cv::Mat& infrared, const cv::Mat& visible, const FusionOptions& o,
                      cv::Mat& out) {
  const int channels = visible.channels();
  std::vector<cv::Mat> planes;
  if (o.method == FusionMethod::fast) {
    const cv::Mat ir = gray_u8(infrared);
    std::vector<cv::Mat> vis_planes;
    cv::split(to_u8(visible), vis_planes);
    const cv::Mat decision = channels == 1 ? vis_planes[0] : gray_u8(visible);
    fast_fuse(ir, vis_planes, decision, planes, o.fast);
  } else {
    for (int k = 0; k < channels; ++k) {
      const cv::Mat ir = plane_unit(infrared, infrared.channels() == 1 ? 0 : k);
      planes.push_back(im2uint8(fuse_plane_vsmwls(ir, plane_unit(visible, k), o.method)));
    }
  }
  cv::merge(planes, out);
}

void fuse_luminance(const cv::Mat& infrared, const cv::Mat& visible, const FusionOptions& o,
                    cv::Mat& out) {
  const cv::Mat ir = gray_u8(infrared);
  const cv::Mat vis = to_u8(visible);
  thread_local cv::Mat luma_buffer;  // reused; never shares the caller's pixels
  cv::Mat luma = vis;
  if (vis.channels() == 3) {
    cv::cvtColor(vis, luma_buffer, cv::COLOR_BGR2GRAY);
    luma = luma_buffer;
  }
  // The luma the fusion sees: enhanced when asked (the colour shift below then carries both
  // the enhancement and the fusion).
  thread_local cv::Mat enhanced_buffer;
  cv::Mat fusion_luma = luma;
  if (o.enhance_visible) {
    enhance::enhance_luma(luma, enhanced_buffer, *o.enhance_visible);
    fusion_luma = enhanced_buffer;
  }
  thread_local std::vector<cv::Mat> fused_luma(1);
  if (o.method == FusionMethod::fast) {
    fast_fuse(ir, {fusion_luma}, fusion_luma, fused_luma, o.fast);
  } else {
    fused_luma[0] =
        im2uint8(fuse_plane_vsmwls(plane_unit(ir, 0), plane_unit(fusion_luma, 0), o.method));
  }
  enhance::replace_luma(vis, luma, fused_luma[0], out);
}

}  // namespace

namespace {

constexpr util::EnumName<FusionMethod> kMethodNames[] = {
    {FusionMethod::vsmwls, "vsmwls"},
    {FusionMethod::vsmwls_paper, "vsmwls-paper"},
    {FusionMethod::fast, "fast"}};

constexpr util::EnumName<ColourMode> kColourNames[] = {{ColourMode::per_channel, "rgb"},
                                                       {ColourMode::luminance, "luminance"}};

}  // namespace

std::string_view method_name(FusionMethod method) {
  return util::name_of(kMethodNames, method, "?");
}

std::optional<FusionMethod> method_from_name(std::string_view name) {
  return util::parse(kMethodNames, name);
}

std::string_view colour_name(ColourMode mode) {
  return util::name_of(kColourNames, mode, "luminance");
}

std::optional<ColourMode> colour_from_name(std::string_view name) {
  return util::parse(kColourNames, name);
}

cv::Mat fuse(const cv::Mat& infrared, const cv::Mat& visible, const FusionOptions& options) {
  cv::Mat fused;
  fuse(infrared, visible, fused, options);
  return fused;
}

void fuse(const cv::Mat& infrared, const cv::Mat& visible, cv::Mat& fused,
          const FusionOptions& options) {
  validate(infrared, "infrared");
  validate(visible, "visible");
  if (infrared.size() != visible.size()) {
    throw std::invalid_argument("infrared and visible images differ in size: " +
                                describe(infrared) + " vs " + describe(visible));
  }
  if (infrared.depth() != visible.depth()) {
    throw std::invalid_argument("infrared and visible images differ in pixel type: " +
                                describe(infrared) + " vs " + describe(visible));
  }
  if (infrared.channels() == 3 && visible.channels() == 1) {
    throw std::invalid_argument("a colour infrared image needs a colour visible image (got " +
                                describe(infrared) + " and " + describe(visible) + ")");
  }
  if (infrared.rows < 18 || infrared.cols < 18) {
    throw std::invalid_argument("images must be at least 18x18 pixels, got " + describe(infrared));
  }
  if (options.colour == ColourMode::per_channel) {
    if (options.enhance_visible) {
      const cv::Mat enhanced = enhance::enhance_visible(to_u8(visible), *options.enhance_visible);
      fuse_per_channel(infrared, enhanced, options, fused);
      return;
    }
    fuse_per_channel(infrared, visible, options, fused);
  } else {
    fuse_luminance(infrared, visible, options, fused);
  }
}

}  // namespace thermovis::fuse
