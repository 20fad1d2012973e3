// thermovis obstacles: the obstacle stage's detector (obstacle::ObstacleDetector: the ground
// from the v-disparity, stixels) on one rectified stereo pair from files, the pinhole pairs a
// stereo data set gives (e.g. the MS2 road frame in ../shared/data/stereo/ms2_sample). The pair
// is resampled onto a cylindrical grid of the same focal length (its rows the same epipolar
// planes, as angles), which is the detector's wide-grid geometry; boxes are reported in the
// input image's pixels.
#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "command.hpp"
#include "thermovis/obstacle/obstacles.hpp"

namespace {

namespace ob = thermovis::obstacle;
namespace cam = thermovis::camera;

struct Options {
  std::string left, right;
  double fx = 0, cx = 0, cy = 0, baseline_m = 0;
  double camera_height_m = 1.4, pitch_deg = 0, roll_deg = 0;
  std::string method = "bm";
  int reduction = 2;
  double min_inlier_share = ob::GroundOptions{}.min_inlier_share;
  double max_distance_m = 60;
  std::string draw;
  bool json = false;
};

// A rectified pinhole pair (focal length f, centre (cx, cy)) on the cylindrical grid of the same
// f: grid pixel (u, v) is the ray alpha = atan((u - cx_g) / f), beta = (v - cy_g) / f, seen in
// the pinhole image at x = (u - cx_g) / cos(beta) + cx, y = f tan(beta) + cy.
struct PinholeOnGrid {
  PinholeOnGrid(cv::Size image, double f, double cx, double cy) : f_(f), cx_(cx), cy_(cy) {
    const double beta_top = std::atan((-0.5 - cy) / f);
    const double beta_bottom = std::atan((image.height - 0.5 - cy) / f);
    grid.width = image.width;
    grid.height = static_cast<int>(std::ceil(f * (beta_bottom - beta_top)));
    grid.f = f;
    grid.cx = cx;
    grid.cy = -beta_top * f - 0.5;
    grid.projection = cam::RectifiedProjection::cylindrical;
    map_x.create(grid.height, grid.width, CV_32FC1);
    map_y.create(grid.height, grid.width, CV_32FC1);
    for (int v = 0; v < grid.height; ++v) {
      for (int u = 0; u < grid.width; ++u) {
        const cv::Point2d p = image_point(u, v);
        map_x.at<float>(v, u) = static_cast<float>(p.x);
        map_y.at<float>(v, u) = static_cast<float>(p.y);
      }
    }
  }
  cv::Point2d image_point(double u, double v) const {
    const double beta = (v - grid.cy) / grid.f;
    return {(u - grid.cx) / std::cos(beta) + cx_, f_ * std::tan(beta) + cy_};
  }
  // A grid box's bounding box in the input image.
  cv::Rect image_box(const cv::Rect& box) const {
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (const double u : {box.x - 0.5, box.br().x - 0.5}) {
      for (const double v : {box.y - 0.5, box.br().y - 0.5}) {
        const cv::Point2d p = image_point(u, v);
        x0 = std::min(x0, p.x);
        y0 = std::min(y0, p.y);
        x1 = std::max(x1, p.x);
        y1 = std::max(y1, p.y);
      }
    }
    return {
        cv::Point(static_cast<int>(std::floor(x0 + 0.5)), static_cast<int>(std::floor(y0 + 0.5))),
        cv::Point(static_cast<int>(std::ceil(x1 + 0.5)), static_cast<int>(std::ceil(y1 + 0.5)))};
  }
  cv::Mat resample(const cv::Mat& image) const {
    cv::Mat out;
    cv::remap(image, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    return out;
  }

  cam::RectifiedIntrinsics grid;
  cv::Mat map_x, map_y;

 private:
  double f_, cx_, cy_;
};

cv::Mat read_image(const std::string& path) {
  cv::Mat m = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (m.empty()) throw std::runtime_error(path + ": cannot read the image");
  if (m.type() != CV_8UC1 && m.type() != CV_8UC3 && m.type() != CV_16UC1) {
    throw std::invalid_argument(path + ": pixel type " + std::to_string(m.type()) +
                                ", expected 8-bit grey or colour, or 16-bit infrared counts");
  }
  return m;
}

// The grey image the drawing is made on (16-bit counts stretched between their 1st and 99th
// percentiles).
cv::Mat display_image(const cv::Mat& image) {
  cv::Mat grey;
  if (image.type() == CV_16UC1) {
    cv::Mat sorted = image.reshape(1, 1).clone();
    cv::sort(sorted, sorted, cv::SORT_ASCENDING);
    const double lo = sorted.at<std::uint16_t>(sorted.cols / 100);
    const double hi = sorted.at<std::uint16_t>(sorted.cols - 1 - sorted.cols / 100);
    image.convertTo(grey, CV_8U, 255.0 / std::max(1.0, hi - lo),
                    -lo * 255.0 / std::max(1.0, hi - lo));
  } else if (image.channels() == 3) {
    grey = image.clone();
  } else {
    grey = image;
  }
  cv::Mat bgr;
  if (grey.channels() == 1) {
    cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  } else {
    bgr = grey;
  }
  return bgr;
}

int run_obstacles(const Options& opt) {
  if (!(opt.fx > 0) || !(opt.baseline_m > 0)) {
    throw std::invalid_argument("--fx and --baseline-m must be > 0");
  }
  const cv::Mat left = read_image(opt.left), right = read_image(opt.right);
  if (left.size() != right.size() || left.type() != right.type()) {
    throw std::invalid_argument(opt.left + " and " + opt.right +
                                ": the two images differ in size or pixel type");
  }
  const PinholeOnGrid on_grid(left.size(), opt.fx, opt.cx, opt.cy);
  const ob::PairBand band =
      left.type() == CV_16UC1 ? ob::PairBand::infrared : ob::PairBand::visible;
  const thermovis::range::RangingGeometry pair{cam::RectifiedCamera(on_grid.grid), opt.baseline_m,
                                               Eigen::Isometry3d::Identity()};
  ob::ObstacleOptions options;
  options.dense.method = ob::parse_dense_method(opt.method);
  options.reduction = opt.reduction;
  options.max_distance_m = opt.max_distance_m;
  options.ground.min_inlier_share = opt.min_inlier_share;
  const ob::GroundPrior prior{opt.camera_height_m, opt.pitch_deg * M_PI / 180.0,
                              opt.roll_deg * M_PI / 180.0};
  const ob::ObstacleDetector detector(on_grid.grid, {{band, pair}}, Eigen::Isometry3d::Identity(),
                                      prior, options);
  const ob::PairObstacles r =
      detector.detect_pair(band, on_grid.resample(left), on_grid.resample(right));

  const double fit_pitch_deg = ob::pitch_of(r.ground.plane) * 180.0 / M_PI;
  if (!opt.draw.empty()) {
    cv::Mat shown = display_image(left);
    for (const ob::Obstacle& o : r.obstacles) {
      const cv::Rect box = on_grid.image_box(o.box);
      cv::rectangle(shown, box, cv::Scalar(255, 64, 255), 2);
      char text[32];
      std::snprintf(text, sizeof text, "%.1f m", o.distance_m);
      cv::putText(shown, text, box.tl() + cv::Point(0, -3), cv::FONT_HERSHEY_SIMPLEX, 0.45,
                  cv::Scalar(255, 64, 255), 1, cv::LINE_AA);
    }
    if (!cv::imwrite(opt.draw, shown)) throw std::runtime_error(opt.draw + ": cannot write");
    // Beside it: the pair's dense disparity on the detector's reduced grid (black: none) and
    // the reduced left image the matcher read.
    cv::Mat l8, r8;
    detector.reduce_pair(band, on_grid.resample(left), on_grid.resample(right), l8, r8);
    const cv::Mat d = detector.disparity(band, on_grid.resample(left), on_grid.resample(right));
    cv::Mat colour;
    d.convertTo(colour, CV_8U, 255.0 / detector.max_disparity_px());
    cv::applyColorMap(colour, colour, cv::COLORMAP_JET);
    colour.setTo(cv::Scalar::all(0), d != d);
    const std::string stem = opt.draw.substr(0, opt.draw.rfind('.'));
    cv::imwrite(stem + "_disparity.png", colour);
    cv::imwrite(stem + "_reduced.png", l8);
  }
  if (opt.json) {
    nlohmann::json obstacles = nlohmann::json::array();
    for (const ob::Obstacle& o : r.obstacles) {
      const cv::Rect box = on_grid.image_box(o.box);
      obstacles.push_back({{"box", {box.x, box.y, box.br().x, box.br().y}},
                           {"distance_m", o.distance_m},
                           {"sigma_m", o.sigma_m},
                           {"position_m", {o.position_m.x(), o.position_m.y(), o.position_m.z()}},
                           {"extent_m", {o.extent_m.x(), o.extent_m.y(), o.extent_m.z()}},
                           {"stixels", o.stixels}});
    }
    std::cout << nlohmann::json{{"left", opt.left},
                                {"band", ob::band_name(band)},
                                {"grid", {on_grid.grid.width, on_grid.grid.height}},
                                {"ground", ob::status_name(r.ground.status)},
                                {"ground_message", r.ground.message},
                                {"ground_height_m", r.ground.plane.height_m},
                                {"ground_pitch_deg", fit_pitch_deg},
                                {"obstacles", obstacles}}
                     .dump()
              << "\n";
    return 0;
  }
  std::cout << opt.left << ": " << ob::band_name(band) << " pair on a " << on_grid.grid.width << "x"
            << on_grid.grid.height << " cylindrical grid; ground "
            << ob::status_name(r.ground.status);
  if (r.ok()) {
    std::cout << " (camera " << r.ground.plane.height_m << " m above it, pitch " << fit_pitch_deg
              << " deg)";
  } else {
    std::cout << ": " << r.ground.message;
  }
  std::cout << "; " << r.obstacles.size() << " obstacles (boxes [x0, y0, x1, y1] of " << opt.left
            << ")\n";
  for (const ob::Obstacle& o : r.obstacles) {
    const cv::Rect box = on_grid.image_box(o.box);
    std::cout << "  [" << box.x << ", " << box.y << ", " << box.br().x << ", " << box.br().y
              << "]  " << o.distance_m << " m +- " << o.sigma_m << "  " << o.extent_m.x() << " x "
              << o.extent_m.y() << " m, " << o.stixels << " stixels\n";
  }
  return 0;
}

THERMOVIS_COMMAND(
    "obstacles",
    "Obstacles (stixels on the ground) of one rectified pinhole stereo pair from files",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--left", opt->left, "left image (8-bit, or 16-bit infrared counts)")
          ->required();
      app.add_option("--right", opt->right, "right image, rectified with the left")->required();
      app.add_option("--fx", opt->fx, "focal length of the rectified pair, px")->required();
      app.add_option("--cx", opt->cx, "principal point column, px")->required();
      app.add_option("--cy", opt->cy, "principal point row, px")->required();
      app.add_option("--baseline-m", opt->baseline_m, "baseline, m")->required();
      app.add_option("--camera-height-m", opt->camera_height_m,
                     "the left camera's height above the ground (the prior; the "
                     "search spans +-15 %)")
          ->capture_default_str();
      app.add_option("--pitch-deg", opt->pitch_deg,
                     "its optical axis below the horizontal > 0 (the prior; the "
                     "search spans +-4 deg)")
          ->capture_default_str();
      app.add_option("--roll-deg", opt->roll_deg, "right side down > 0")->capture_default_str();
      app.add_option("--method", opt->method, "dense disparity: bm | sgbm")
          ->capture_default_str()
          ->check(CLI::IsMember({"bm", "sgbm"}));
      app.add_option("--reduction", opt->reduction,
                     "grid px per reduced px (2 as the pipeline; 1 for a small "
                     "image)")
          ->capture_default_str()
          ->check(CLI::Range(1, 8));
      app.add_option("--min-inlier-share", opt->min_inlier_share,
                     "share of the searched rows' disparities on the ground a fit needs")
          ->capture_default_str()
          ->check(CLI::Range(0.0, 1.0));
      app.add_option("--max-distance-m", opt->max_distance_m, "farthest obstacle reported")
          ->capture_default_str()
          ->check(CLI::PositiveNumber);
      app.add_option("--draw", opt->draw, "write the left image with the obstacles");
      app.add_flag("--json", opt->json, "one JSON object");
      return [opt] { return run_obstacles(*opt); };
    });

}  // namespace
