#pragma once
// The VIFB fusion benchmark's folder as the fusion and metric tests read it: VI/ and IR/ hold
// one JPEG per image pair under the same name (header-only; the tests link opencv_imgcodecs).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

namespace thermovis::test {

// The image at `path` as stored (depth and channels unchanged); a test failure naming the file,
// and an empty image, when it cannot be read.
inline cv::Mat read_image(const std::filesystem::path& path) {
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (image.empty()) ADD_FAILURE() << "cannot read " << path;
  return image;
}

// The pairs' names (file stems of VI/), sorted.
inline std::vector<std::string> vifb_names(const std::filesystem::path& vifb_dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(vifb_dir / "VI"))
    names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace thermovis::test
