// thermovis range: distance, 3-D position and uncertainty of each target box in one frame set of
// the rig (a folder written by `thermovis scene render`, or any four raw images named
// visible_left/visible_right/infrared_left/infrared_right .png), one JSON object per target.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "command.hpp"
#include "thermovis/json/fields.hpp"
#include "thermovis/pipeline/capture_pipeline.hpp"
#include "thermovis/runtime/grid_options.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace {

namespace fs = std::filesystem;
namespace rg = thermovis::range;
namespace pl = thermovis::pipeline;

struct Options {
  std::string rig;
  std::string images;
  std::string boxes;
  std::string mode = "fused";
  std::string method = "ncc";
  double min_distance_m = 2.5;
  int fast_threshold = 0;
  int patch_radius = 0;
  bool surface = false;
  bool detect = false;
  double camera_height_m = 1.4;
  bool json = false;
  pl::GridOptions grid;
};

cv::Mat read_image(const fs::path& path, int flags) {
  if (!fs::exists(path)) throw std::runtime_error("missing image " + path.string());
  cv::Mat image = cv::imread(path.string(), flags);
  if (image.empty()) throw std::runtime_error("cannot read image " + path.string());
  return image;
}

struct BoxRequest {
  std::string id, cls;
  std::optional<cv::Rect> rectified;                  // on the mode's left grid
  std::optional<std::array<double, 4>> raw_visible;   // raw visible_left box
  std::optional<std::array<double, 4>> raw_infrared;  // raw infrared_left box
  std::optional<double> truth_distance_m;
};

std::array<double, 4> box4(const nlohmann::json& entry, const std::string& name,
                           const std::string& where) {
  const nlohmann::json& j = entry.at(name);
  if (!j.is_array() || j.size() != 4)
    throw std::runtime_error(where + ": field '" + name +
                             "' must be a box [x_min, y_min, x_max, y_max], got " + j.dump());
  std::array<double, 4> b{};
  for (size_t i = 0; i < 4; ++i) {
    if (!j[i].is_number())
      throw std::runtime_error(where + ": field '" + name + "' value " + std::to_string(i) +
                               " must be a number, got " + j[i].dump());
    b[i] = j[i].get<double>();
  }
  return b;
}

// Boxes file: {"targets": [...]} (truth.json of `scene render` is one) or a bare array; each
// entry has "id", "class" and either "rectified_box" [x_min, y_min, x_max, y_max] on the left
// rectified grid of the mode, or "boxes" {"visible_left": [...], "infrared_left": [...]} on raw
// images; "distance_m" (truth) is used to report the error.
std::vector<BoxRequest> read_boxes(const fs::path& path) {
  namespace tj = thermovis::json;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open boxes file " + path.string());
  nlohmann::json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    throw std::runtime_error(path.string() + ": not JSON (" + e.what() + ")");
  }
  const nlohmann::json& list = j.is_array() ? j : j.value("targets", nlohmann::json::array());
  if (!list.is_array()) throw std::runtime_error(path.string() + ": 'targets' must be an array");
  std::vector<BoxRequest> out;
  for (size_t i = 0; i < list.size(); ++i) {
    const auto& t = list[i];
    const std::string where = path.string() + " target " + std::to_string(i);
    BoxRequest b;
    b.id = tj::field_or<std::string>(t, "id", where, "target" + std::to_string(i));
    b.cls = tj::field_or<std::string>(t, "class", where, "person");
    if (t.contains("distance_m") && !t["distance_m"].is_null())
      b.truth_distance_m = tj::field<double>(t, "distance_m", where);
    if (t.contains("rectified_box")) {
      const auto r = box4(t, "rectified_box", where);
      b.rectified = cv::Rect(
          cv::Point(static_cast<int>(std::floor(r[0])), static_cast<int>(std::floor(r[1]))),
          cv::Point(static_cast<int>(std::ceil(r[2])) + 1, static_cast<int>(std::ceil(r[3])) + 1));
    } else if (t.contains("boxes")) {
      const auto& boxes = t["boxes"];
      tj::require_object(boxes, where + " field 'boxes'");
      if (boxes.contains("visible_left") && !boxes["visible_left"].is_null())
        b.raw_visible = box4(boxes, "visible_left", where + " boxes");
      if (boxes.contains("infrared_left") && !boxes["infrared_left"].is_null())
        b.raw_infrared = box4(boxes, "infrared_left", where + " boxes");
    } else {
      throw std::runtime_error(where + ": needs 'rectified_box' or 'boxes'");
    }
    out.push_back(b);
  }
  return out;
}

pl::BandChoice band_of_mode(const std::string& mode) {
  if (mode == "visible") return pl::BandChoice::visible;
  if (mode == "infrared") return pl::BandChoice::infrared;
  if (mode == "fused") return pl::BandChoice::both;
  throw std::invalid_argument("unknown ranging mode '" + mode +
                              "' (expected visible, infrared or fused)");
}

int run_range(const Options& opt) {
  const fs::path dir(opt.images);
  if (!fs::is_directory(dir)) throw std::runtime_error("--images: no folder " + opt.images);
  const pl::BandChoice band = band_of_mode(opt.mode);
  if (opt.detect && !opt.boxes.empty())
    throw std::invalid_argument("give --boxes or --detect, not both");
  std::vector<BoxRequest> requests;
  if (!opt.detect) {
    const fs::path boxes_path = opt.boxes.empty() ? dir / "truth.json" : fs::path(opt.boxes);
    if (!fs::exists(boxes_path)) {
      throw std::runtime_error("no boxes: give --boxes B.json or --detect (no truth.json in " +
                               opt.images + ")");
    }
    requests = read_boxes(boxes_path);
  }
  const auto rig = thermovis::runtime::load_rig_or_default(opt.rig);
  pl::RawCapture raw;
  raw.visible_left = read_image(dir / "visible_left.png", cv::IMREAD_COLOR);
  raw.visible_right = read_image(dir / "visible_right.png", cv::IMREAD_COLOR);
  raw.infrared_left = read_image(dir / "infrared_left.png", cv::IMREAD_UNCHANGED);
  raw.infrared_right = read_image(dir / "infrared_right.png", cv::IMREAD_UNCHANGED);
  pl::CapturePipelineOptions options;
  options.grid = opt.grid;
  options.rectify.agc.temporal_alpha = 1.0;  // one frame set on its own
  options.detect.blobs.camera_height_m = opt.camera_height_m;
  options.match.match.method = thermovis::match::parse_method(opt.method);
  options.match.min_distance_m = opt.min_distance_m;
  if (opt.fast_threshold > 0) options.match.match.fast_threshold = opt.fast_threshold;
  if (opt.patch_radius > 0) options.match.match.patch_radius = opt.patch_radius;
  options.range.surface = opt.surface;
  pl::CapturePipeline pipeline(rig, options);
  const pl::GridCapture capture = pipeline.rectify(raw);
  if (opt.detect) {
    // The detect service's stage: warm blobs on the rectified infrared counts (the infrared
    // camera 60 mm below the visible one in the paper rig: its height is --camera-height). Every
    // band is on the one grid, so the boxes serve every mode.
    const auto found = pipeline.detect(capture);
    for (size_t i = 0; i < found.size(); ++i) {
      BoxRequest b;
      b.id = "detection" + std::to_string(i);
      b.cls = found[i].cls;
      b.rectified = found[i].box;
      requests.push_back(b);
    }
  }
  for (const BoxRequest& request : requests) {
    cv::Rect box;
    if (request.rectified) {
      box = *request.rectified;
    } else {
      const bool infrared = band == pl::BandChoice::infrared && request.raw_infrared;
      const auto& raw_box = infrared ? request.raw_infrared : request.raw_visible;
      if (raw_box) {
        box = pl::raw_box_on_grid(pipeline.geometry(), rig,
                                  infrared ? pl::Band::infrared : pl::Band::visible, (*raw_box)[0],
                                  (*raw_box)[1], (*raw_box)[2], (*raw_box)[3]);
      }
    }
    const pl::CaptureTarget t = pipeline.range(capture, box, request.cls, band, true);
    const rg::TargetRange& r = t.ranged.range;
    auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
    const int keypoints = t.matches.empty() ? 0 : t.matches.front().result.keypoints_left;
    nlohmann::json out{{"id", request.id},
                       {"class", request.cls},
                       {"mode", opt.mode},
                       {"band", pl::band_name(t.ranged.band)},
                       {"status", rg::status_name(r.status)},
                       {"message", r.message},
                       {"box", {box.x, box.y, box.x + box.width - 1, box.y + box.height - 1}},
                       {"distance_m", number(t.ranged.distance_m)},
                       {"depth_m", number(r.depth_m)},
                       {"sigma_m", number(r.sigma_m)},
                       {"position_m",
                        {number(t.ranged.position_m.x()), number(t.ranged.position_m.y()),
                         number(t.ranged.position_m.z())}},
                       {"frame_of_position", rig.visible.left},
                       {"disparity_px", number(r.disparity_px)},
                       {"points_used", r.points_used},
                       {"points_valid", r.points_valid},
                       {"matches", r.points_total},
                       {"keypoints", keypoints},
                       {"region_pixels", r.region_pixels}};
    // Each pair's whole-region alignment (thermovis::match::align_region).
    nlohmann::json regions;
    for (const pl::BandMatches& m : t.matches) {
      const thermovis::match::RegionDisparity& q = m.result.region;
      regions[pl::band_name(m.band)] = {{"status", thermovis::match::region_status_name(q.status)},
                                        {"message", q.message},
                                        {"disparity_px", number(q.disparity_px)},
                                        {"sigma_px", number(q.sigma_px)},
                                        {"zncc", q.zncc},
                                        {"contour_fraction", number(q.contour_fraction)},
                                        {"pixels", q.pixels}};
    }
    out["regions"] = regions;
    if (t.each_band.size() > 1) {
      // Each pair's own range, as combined into the target's.
      nlohmann::json bands;
      for (std::size_t i = 0; i < t.each_band.size(); ++i) {
        const pl::RangedTarget& b = t.each_band[i];
        bands[pl::band_name(t.matches[i].band)] = {{"status", rg::status_name(b.range.status)},
                                                   {"message", b.range.message},
                                                   {"box", out["box"]},
                                                   {"distance_m", number(b.distance_m)},
                                                   {"sigma_m", number(b.range.sigma_m)},
                                                   {"points_used", b.range.points_used}};
      }
      out["bands"] = bands;
    }
    if (request.truth_distance_m) {
      out["truth_distance_m"] = *request.truth_distance_m;
      out["error_m"] = number(t.ranged.distance_m - *request.truth_distance_m);
    }
    if (opt.json) {
      std::cout << out.dump() << "\n";
      continue;
    }
    std::cout << std::left << std::setw(14) << request.id << std::right << " " << std::setw(9)
              << opt.mode << "  ";
    if (t.ranged.ok()) {
      std::cout << std::fixed << std::setprecision(3) << t.ranged.distance_m << " m +- "
                << r.sigma_m << " (" << r.points_used << "/" << r.points_valid << " points)";
      if (t.each_band.size() > 1) {
        std::cout << " [";
        for (std::size_t i = 0; i < t.each_band.size(); ++i) {
          const pl::RangedTarget& b = t.each_band[i];
          std::cout << (i ? ", " : "") << pl::band_name(t.matches[i].band) << " ";
          if (b.ok()) {
            std::cout << b.distance_m << " +- " << b.range.sigma_m;
          } else {
            std::cout << rg::status_name(b.range.status);
          }
        }
        std::cout << "]";
      }
      if (request.truth_distance_m) std::cout << "  truth " << *request.truth_distance_m << " m";
    } else {
      std::cout << rg::status_name(r.status) << ": " << r.message;
    }
    std::cout << "\n";
  }
  return 0;
}

THERMOVIS_COMMAND(
    "range", "Distance, 3-D position and uncertainty of each target box of one frame set",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--rig", opt->rig, "rig YAML (default: deploy/rigs/paper.yaml)");
      app.add_option("--images", opt->images,
                     "folder with visible_left/right.png, infrared_left/right.png "
                     "(e.g. a frame folder of `thermovis scene render`)")
          ->required();
      app.add_option("--boxes", opt->boxes,
                     "boxes JSON (default: the folder's truth.json); see docs/commands/range.md");
      app.add_option("--mode", opt->mode, "fused | visible | infrared")->capture_default_str();
      app.add_option("--method", opt->method, "matching: ncc | orb | akaze | sift | sgbm")
          ->capture_default_str();
      app.add_option("--min-distance", opt->min_distance_m, "nearest target distance searched, m")
          ->capture_default_str();
      app.add_option("--fast-threshold", opt->fast_threshold,
                     "ncc: FAST threshold, grey levels (default 12)");
      app.add_option("--patch-radius", opt->patch_radius,
                     "correlation patch radius, px (default 4)");
      app.add_flag("--surface", opt->surface,
                   "report the distance of the target's visible surface (default: "
                   "its centre, by the class's known depth)");
      app.add_flag("--detect", opt->detect,
                   "detect people as warm blobs in the infrared image instead of reading boxes");
      app.add_option("--camera-height", opt->camera_height_m,
                     "infrared camera height above the ground, m (--detect's size check)")
          ->capture_default_str();
      app.add_flag("--json", opt->json, "one JSON object per target");
      thermovis::runtime::add_grid_options(app, opt->grid);
      return [opt] { return run_range(*opt); };
    });

}  // namespace
