#include "thermovis/match/middlebury.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>

namespace thermovis::match {

cv::Mat read_pfm(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open PFM file " + path.string());
  std::string magic;
  int width = 0, height = 0;
  double scale = 0;
  in >> magic >> width >> height >> scale;
  if (magic != "Pf") {
    throw std::runtime_error(path.string() + ": not a one-channel PFM (magic '" + magic + "')");
  }
  if (!in || width <= 0 || height <= 0 || scale == 0.0) {
    throw std::runtime_error(path.string() + ": broken PFM header");
  }
  in.get();  // the single whitespace byte after the scale
  cv::Mat image(height, width, CV_32FC1);
  const bool little_endian_file = scale < 0;
  std::vector<char> row(static_cast<size_t>(width) * 4);
  for (int y = height - 1; y >= 0; --y) {
    if (!in.read(row.data(), static_cast<std::streamsize>(row.size()))) {
      throw std::runtime_error(path.string() + ": truncated PFM data");
    }
    float* out = image.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      unsigned char b[4];
      std::memcpy(b, &row[static_cast<size_t>(x) * 4], 4);
      if (!little_endian_file) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
      std::memcpy(&out[x], b, 4);  // the host is little-endian (x86-64, aarch64)
    }
  }
  return image;
}

namespace {
cv::Mat read_image(const std::filesystem::path& path) {
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
  if (image.empty()) throw std::runtime_error("cannot read image " + path.string());
  return image;
}
}  // namespace

MiddleburyScene load_middlebury_scene(const std::filesystem::path& folder) {
  MiddleburyScene scene;
  scene.name = folder.filename().string();
  scene.left = read_image(folder / "im0.png");
  scene.right = read_image(folder / "im1.png");
  scene.ground_truth = read_pfm(folder / "disp0GT.pfm");
  if (scene.ground_truth.size() != scene.left.size() || scene.right.size() != scene.left.size()) {
    throw std::runtime_error(folder.string() + ": images and ground truth differ in size");
  }
  std::ifstream calib(folder / "calib.txt");
  if (!calib) throw std::runtime_error("cannot open " + (folder / "calib.txt").string());
  std::string line;
  while (std::getline(calib, line)) {
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    std::string key = line.substr(0, eq);
    key.erase(0, key.find_first_not_of(" \t"));
    key.erase(key.find_last_not_of(" \t") + 1);
    if (key == "ndisp") scene.ndisp = std::stod(line.substr(eq + 1));
  }
  if (!(scene.ndisp > 0)) throw std::runtime_error(folder.string() + "/calib.txt: no ndisp");
  return scene;
}

MatchAccuracy evaluate_matches(const std::vector<Correspondence>& matches, const cv::Mat& gt) {
  MatchAccuracy a;
  a.matches = static_cast<int>(matches.size());
  double sum_abs = 0;
  for (const Correspondence& m : matches) {
    const int x = static_cast<int>(std::lround(m.left.x())),
              y = static_cast<int>(std::lround(m.left.y()));
    if (x < 0 || y < 0 || x >= gt.cols || y >= gt.rows) continue;
    const float truth = gt.at<float>(y, x);
    if (!std::isfinite(truth)) continue;
    ++a.with_truth;
    const double error = std::abs(m.disparity_px - truth);
    if (error <= 1.0) {
      ++a.within_1px;
      sum_abs += error;
    }
    if (error <= 0.5) ++a.within_half_px;
  }
  a.mean_abs_error_px = a.within_1px ? sum_abs / a.within_1px : 0.0;
  return a;
}

}  // namespace thermovis::match
