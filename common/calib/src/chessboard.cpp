#include "thermovis/calib/chessboard.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace thermovis::calib {
namespace {

cv::Mat to_grey8(const cv::Mat& image) {
  if (image.empty()) throw std::invalid_argument("chessboard detection: empty image");
  cv::Mat grey;
  if (image.type() == CV_8UC1) {
    grey = image;
  } else if (image.type() == CV_8UC3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.type() == CV_8UC4) {
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  } else if (image.type() == CV_16UC1) {
    cv::normalize(image, grey, 0, 255, cv::NORM_MINMAX, CV_8U);
  } else {
    throw std::invalid_argument(
        "chessboard detection: image type must be 8-bit grey/BGR or 16-bit grey, got " +
        cv::typeToString(image.type()));
  }
  return grey;
}

// One preprocessed version of the image; a pixel (x, y) of it is (x, y) * scale + offset
// in the raw image (pixel centres, OpenCV's resize convention).
struct Variant {
  std::string name;
  cv::Mat image;
  double scale = 1.0;
};

std::vector<Variant> variants(const cv::Mat& grey) {
  std::vector<Variant> out;
  out.push_back({"plain", grey, 1.0});
  cv::Mat equalised;
  cv::createCLAHE(2.0, {8, 8})->apply(grey, equalised);
  out.push_back({"clahe", equalised, 1.0});
  if (std::max(grey.cols, grey.rows) <= 800) {  // small images only: the cost grows fast
    cv::Mat up;
    cv::resize(equalised, up, {}, 2.0, 2.0, cv::INTER_CUBIC);
    out.push_back({"clahe-x2", up, 0.5});
  }
  cv::Mat blurred;
  cv::GaussianBlur(equalised, blurred, {5, 5}, 1.2);
  out.push_back({"clahe-blur", blurred, 1.0});
  out.push_back({"inverted", 255 - grey, 1.0});
  return out;
}

// The sector-based detector's exhaustive search is what finds boards bent by a mirror, but it
// is slow on large (upscaled, unwrapped) images, where it runs without it.
bool run_opencv(const cv::Mat& image, cv::Size pattern, bool sector_based, bool exhaustive,
                std::vector<cv::Point2f>& found) {
  found.clear();
  if (sector_based) {
    return cv::findChessboardCornersSB(image, pattern, found,
                                       cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_ACCURACY |
                                           (exhaustive ? cv::CALIB_CB_EXHAUSTIVE : 0));
  }
  return cv::findChessboardCorners(image, pattern, found,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
}

double neighbour_distance(const std::vector<Eigen::Vector2d>& corners, cv::Size grid, int r,
                          int c) {
  double best = std::numeric_limits<double>::infinity();
  const Eigen::Vector2d& p = corners[static_cast<size_t>(r * grid.width + c)];
  const int dr[] = {-1, 1, 0, 0}, dc[] = {0, 0, -1, 1};
  for (int k = 0; k < 4; ++k) {
    const int rr = r + dr[k], cc = c + dc[k];
    if (rr < 0 || cc < 0 || rr >= grid.height || cc >= grid.width) continue;
    best = std::min(best, (corners[static_cast<size_t>(rr * grid.width + cc)] - p).norm());
  }
  return best;
}

// A grid whose corners merged, left the image or zig-zag is a false detection.
bool plausible_grid(const std::vector<Eigen::Vector2d>& corners, cv::Size grid, cv::Size image) {
  for (const auto& p : corners) {
    if (!p.allFinite() || p.x() < 0 || p.y() < 0 || p.x() > image.width - 1 ||
        p.y() > image.height - 1)
      return false;
  }
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      if (neighbour_distance(corners, grid, r, c) < 2.0) return false;
    }
  }
  // Along rows and columns the grid bends smoothly: the second difference of three
  // consecutive corners stays well below their spacing.
  auto at = [&](int r, int c) { return corners[static_cast<size_t>(r * grid.width + c)]; };
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      if (c > 0 && c + 1 < grid.width) {
        const Eigen::Vector2d a = at(r, c - 1), b = at(r, c), d = at(r, c + 1);
        if ((a - 2 * b + d).norm() > 0.5 * (d - a).norm()) return false;
      }
      if (r > 0 && r + 1 < grid.height) {
        const Eigen::Vector2d a = at(r - 1, c), b = at(r, c), d = at(r + 1, c);
        if ((a - 2 * b + d).norm() > 0.5 * (d - a).norm()) return false;
      }
    }
  }
  return true;
}

// Polar unwrapping about the image centre: a catadioptric image becomes a panorama whose rows
// are azimuth and columns radius. 1.5 turns are stacked so a board across azimuth 0 stays whole.
struct PolarView {
  cv::Mat image;
  cv::Point2d centre;
  double radius_per_col = 1.0;  // px of raw radius per column
  double angle_per_row = 0.0;   // rad per row
};

PolarView polar_unwrap(const cv::Mat& grey, double reference_radius, double oversample) {
  PolarView pv;
  pv.centre = {0.5 * (grey.cols - 1), 0.5 * (grey.rows - 1)};
  const double max_radius = 0.5 * std::hypot(grey.cols, grey.rows);
  const int radius_bins = static_cast<int>(std::lround(max_radius * oversample));
  const int angle_bins =
      static_cast<int>(std::lround(2.0 * std::numbers::pi * reference_radius * oversample));
  cv::Mat turn;
  cv::warpPolar(grey, turn, {radius_bins, angle_bins}, pv.centre, max_radius,
                cv::INTER_CUBIC | cv::WARP_FILL_OUTLIERS | cv::WARP_POLAR_LINEAR);
  cv::vconcat(turn, turn.rowRange(0, angle_bins / 2), pv.image);
  pv.radius_per_col = max_radius / radius_bins;
  pv.angle_per_row = 2.0 * std::numbers::pi / angle_bins;
  return pv;
}

Eigen::Vector2d from_polar(const PolarView& pv, const cv::Point2f& p) {
  const double radius = p.x * pv.radius_per_col, angle = p.y * pv.angle_per_row;
  return {pv.centre.x + radius * std::cos(angle), pv.centre.y + radius * std::sin(angle)};
}

double sample(const cv::Mat& grey, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= grey.cols || y0 + 1 >= grey.rows) return -1.0;
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int yy, int xx) { return static_cast<double>(grey.at<uchar>(yy, xx)); };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
         fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
}

// A checkerboard corner is a saddle: on small circles around it the intensity runs dark, light,
// dark, light (four sectors, opposite sectors alike) with clear contrast. A point on the
// board's white border or beside an occluder fails on at least one of the two circles.
bool is_saddle(const cv::Mat& grey, const Eigen::Vector2d& p, double spacing) {
  for (double fraction : {0.2, 0.35}) {
    const double radius = std::clamp(fraction * spacing, 1.5, 12.0);
    constexpr int kSamples = 64;
    std::array<double, kSamples> ring{};
    double lo = 1e9, hi = -1e9;
    for (int k = 0; k < kSamples; ++k) {
      const double a = 2.0 * std::numbers::pi * k / kSamples;
      const double v = sample(grey, p.x() + radius * std::cos(a), p.y() + radius * std::sin(a));
      if (v < 0) return false;
      ring[static_cast<size_t>(k)] = v;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    if (hi - lo < 20.0) return false;
    const double mid = 0.5 * (lo + hi);
    int changes = 0, opposite_agree = 0;
    for (int k = 0; k < kSamples; ++k) {
      const bool here = ring[static_cast<size_t>(k)] > mid;
      changes += here != (ring[static_cast<size_t>((k + 1) % kSamples)] > mid);
      opposite_agree += here == (ring[static_cast<size_t>((k + kSamples / 2) % kSamples)] > mid);
    }
    if (changes != 4 || opposite_agree < 0.8 * kSamples) return false;
  }
  return true;
}

// Where the grid predicts corner (r, c): a quadratic surface image(r, c) fitted by least
// squares to the corners within two grid steps (bent rows and columns of fisheye and
// catadioptric images are locally quadratic), leaving out (r, c) and corners marked bad.
bool predict_from_neighbours(const std::vector<Eigen::Vector2d>& corners, cv::Size grid,
                             const std::vector<bool>& bad, int r, int c, Eigen::Vector2d& out) {
  std::vector<Eigen::Matrix<double, 6, 1>> rows;
  std::vector<Eigen::Vector2d> targets;
  for (int rr = std::max(0, r - 2); rr <= std::min(grid.height - 1, r + 2); ++rr) {
    for (int cc = std::max(0, c - 2); cc <= std::min(grid.width - 1, c + 2); ++cc) {
      const size_t k = static_cast<size_t>(rr * grid.width + cc);
      if ((rr == r && cc == c) || bad[k]) continue;
      const double y = rr - r, x = cc - c;
      Eigen::Matrix<double, 6, 1> row;
      row << 1, x, y, x * x, x * y, y * y;
      rows.push_back(row);
      targets.push_back(corners[k]);
    }
  }
  if (rows.size() < 8) return false;
  Eigen::MatrixXd A(rows.size(), 6);
  Eigen::MatrixXd B(rows.size(), 2);
  for (size_t i = 0; i < rows.size(); ++i) {
    A.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
    B.row(static_cast<Eigen::Index>(i)) = targets[i].transpose();
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < 6) return false;
  const Eigen::MatrixXd coeff = qr.solve(B);
  out = coeff.row(0).transpose();  // the surface at (0, 0) = (r, c)
  return out.allFinite();
}

// Corners that are not saddles or disagree with their neighbours' prediction (detectors that
// extrapolate the grid, as the sector-based one does, can put a corner on the board's white
// border or on an occluder) are predicted again from the good ones and refined with a small
// window; those that still fail are marked missing (NaN). Returns how many are missing.
int repair_corners(const cv::Mat& grey, cv::Size grid, std::vector<Eigen::Vector2d>& corners) {
  const size_t n = corners.size();
  const std::vector<Eigen::Vector2d> detected = corners;
  std::vector<bool> bad(n, false);
  auto spacing_at = [&](int r, int c) { return neighbour_distance(detected, grid, r, c); };
  auto tolerance = [&](int r, int c) { return std::max(1.5, 0.2 * spacing_at(r, c)); };
  for (int r = 0; r < grid.height; ++r)
    for (int c = 0; c < grid.width; ++c)
      if (!is_saddle(grey, detected[static_cast<size_t>(r * grid.width + c)], spacing_at(r, c)))
        bad[static_cast<size_t>(r * grid.width + c)] = true;
  // Mark the worst offender first, so one bad corner does not condemn its neighbours.
  for (size_t round = 0; round < n; ++round) {
    double worst_ratio = 1.0;
    size_t worst = n;
    for (int r = 0; r < grid.height; ++r) {
      for (int c = 0; c < grid.width; ++c) {
        const size_t k = static_cast<size_t>(r * grid.width + c);
        Eigen::Vector2d predicted;
        if (bad[k] || !predict_from_neighbours(detected, grid, bad, r, c, predicted)) continue;
        const double ratio = (predicted - detected[k]).norm() / tolerance(r, c);
        if (ratio > worst_ratio) {
          worst_ratio = ratio;
          worst = k;
        }
      }
    }
    if (worst == n) break;
    bad[worst] = true;
  }
  const cv::TermCriteria criteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3);
  int missing = 0;
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      const size_t k = static_cast<size_t>(r * grid.width + c);
      if (!bad[k]) continue;
      bool repaired = false;
      Eigen::Vector2d predicted;
      if (predict_from_neighbours(detected, grid, bad, r, c, predicted)) {
        const double spacing = spacing_at(r, c);
        const int half = std::clamp(static_cast<int>(std::lround(0.25 * spacing)), 2, 5);
        std::vector<cv::Point2f> one{
            cv::Point2f(static_cast<float>(predicted.x()), static_cast<float>(predicted.y()))};
        if (one[0].x >= half + 1 && one[0].y >= half + 1 && one[0].x <= grey.cols - half - 2 &&
            one[0].y <= grey.rows - half - 2) {
          cv::cornerSubPix(grey, one, {half, half}, {-1, -1}, criteria);
          const Eigen::Vector2d refined(one[0].x, one[0].y);
          if ((refined - predicted).norm() <= tolerance(r, c) &&
              is_saddle(grey, refined, spacing)) {
            corners[k] = refined;
            repaired = true;
          }
        }
      }
      if (!repaired) {
        corners[k] = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
        ++missing;
      }
    }
  }
  return missing;
}

bool finish(const cv::Mat& grey, cv::Size pattern, std::vector<Eigen::Vector2d> corners,
            const std::string& method, ChessboardDetection& out) {
  refine_corners(grey, pattern, corners);
  if (!plausible_grid(corners, pattern, grey.size())) return false;
  canonical_order(pattern, corners);
  const int missing = repair_corners(grey, pattern, corners);
  if (missing > static_cast<int>(corners.size()) / 10) return false;
  out.missing = missing;
  out.found = true;
  out.corners = std::move(corners);
  out.method = method;
  return true;
}

}  // namespace

void refine_corners(const cv::Mat& grey, cv::Size inner_corners,
                    std::vector<Eigen::Vector2d>& corners) {
  const std::vector<Eigen::Vector2d> start = corners;
  const cv::TermCriteria criteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3);
  for (int r = 0; r < inner_corners.height; ++r) {
    for (int c = 0; c < inner_corners.width; ++c) {
      const double spacing = neighbour_distance(start, inner_corners, r, c);
      const int half = std::clamp(static_cast<int>(std::lround(0.35 * spacing)), 2, 11);
      auto& p = corners[static_cast<size_t>(r * inner_corners.width + c)];
      std::vector<cv::Point2f> one{
          cv::Point2f(static_cast<float>(p.x()), static_cast<float>(p.y()))};
      if (one[0].x < half + 1 || one[0].y < half + 1 || one[0].x > grey.cols - half - 2 ||
          one[0].y > grey.rows - half - 2)
        continue;  // too close to the border for a full window: keep the detector's value
      cv::cornerSubPix(grey, one, {half, half}, {-1, -1}, criteria);
      p = Eigen::Vector2d(one[0].x, one[0].y);
    }
  }
}

void canonical_order(cv::Size grid, std::vector<Eigen::Vector2d>& corners) {
  const int w = grid.width, h = grid.height;
  auto at = [&](const std::vector<Eigen::Vector2d>& pts, int r, int c) {
    return pts[static_cast<size_t>(r * w + c)];
  };
  // Mean direction of the board's x axis (along a row) and y axis (along a column).
  Eigen::Vector2d x_dir = Eigen::Vector2d::Zero(), y_dir = Eigen::Vector2d::Zero();
  for (int r = 0; r < h; ++r) x_dir += at(corners, r, w - 1) - at(corners, r, 0);
  for (int c = 0; c < w; ++c) y_dir += at(corners, h - 1, c) - at(corners, 0, c);
  x_dir.normalize();
  y_dir.normalize();
  double best_score = -1e9;
  bool best_flip_x = false, best_flip_y = false;
  for (bool flip_x : {false, true}) {
    for (bool flip_y : {false, true}) {
      const Eigen::Vector2d xd = flip_x ? Eigen::Vector2d(-x_dir) : x_dir;
      const Eigen::Vector2d yd = flip_y ? Eigen::Vector2d(-y_dir) : y_dir;
      const double score = xd.x() + yd.y() + 0.5 * (xd.y() + yd.x());
      if (score > best_score) {
        best_score = score;
        best_flip_x = flip_x;
        best_flip_y = flip_y;
      }
    }
  }
  std::vector<Eigen::Vector2d> out(corners.size());
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c)
      out[static_cast<size_t>(r * w + c)] =
          at(corners, best_flip_y ? h - 1 - r : r, best_flip_x ? w - 1 - c : c);
  corners = std::move(out);
}

ChessboardDetection detect_chessboard(const cv::Mat& image, cv::Size pattern,
                                      const ChessboardOptions& options) {
  if (pattern.width < 2 || pattern.height < 2)
    throw std::invalid_argument("chessboard detection: board needs at least 2x2 inner corners");
  const cv::Mat grey = to_grey8(image);
  ChessboardDetection out;
  std::vector<cv::Point2f> found;

  for (const auto& v : variants(grey)) {
    for (bool sector_based : {false, true}) {
      if (!run_opencv(v.image, pattern, sector_based, v.scale == 1.0, found)) continue;
      std::vector<Eigen::Vector2d> corners;
      for (const auto& p : found)
        corners.emplace_back((p.x + 0.5) * v.scale - 0.5, (p.y + 0.5) * v.scale - 0.5);
      if (finish(grey, pattern, std::move(corners),
                 std::string(sector_based ? "opencv-sb/" : "opencv/") + v.name, out))
        return out;
    }
  }
  if (!options.try_polar_unwrap) return out;

  cv::Mat equalised;
  cv::createCLAHE(2.0, {8, 8})->apply(grey, equalised);
  const double short_side = std::min(grey.cols, grey.rows);
  for (double radius_fraction : {0.3, 0.2}) {
    for (double oversample : {1.0}) {
      const PolarView pv = polar_unwrap(equalised, radius_fraction * short_side, oversample);
      for (bool sector_based : {false, true}) {
        if (!run_opencv(pv.image, pattern, sector_based, false, found)) continue;
        std::vector<Eigen::Vector2d> corners;
        for (const auto& p : found) corners.push_back(from_polar(pv, p));
        if (finish(grey, pattern, std::move(corners),
                   std::string(sector_based ? "polar-sb/" : "polar/") +
                       std::to_string(radius_fraction) + "/" + std::to_string(oversample),
                   out))
          return out;
      }
    }
  }
  return out;
}

cv::Mat read_image(const std::string& path) {
  if (!std::filesystem::exists(path)) throw std::runtime_error("image not found: " + path);
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw std::runtime_error("cannot read image (not an image?): " + path);
  if (image.depth() == CV_16U && image.channels() == 3) {
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    image = grey;
  }
  return image;
}

namespace {

// Natural order: digit runs compare by value, so image2 sorts before image10.
bool natural_less(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      const std::string na = a.substr(i, ie - i), nb = b.substr(j, je - j);
      const unsigned long long va = std::stoull(na), vb = std::stoull(nb);
      if (va != vb) return va < vb;
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

}  // namespace

std::vector<std::string> list_image_files(const std::string& folder) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(folder)) throw std::runtime_error("not a folder: " + folder);
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (!entry.is_regular_file()) continue;
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    for (const char* known : {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm"}) {
      if (ext == known) {
        files.push_back(entry.path().string());
        break;
      }
    }
  }
  if (files.empty()) throw std::runtime_error("no images (.png .jpg .bmp .tif .pgm) in " + folder);
  std::sort(files.begin(), files.end(), [](const std::string& a, const std::string& b) {
    return natural_less(std::filesystem::path(a).filename().string(),
                        std::filesystem::path(b).filename().string());
  });
  return files;
}

}  // namespace thermovis::calib
