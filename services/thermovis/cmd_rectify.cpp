// thermovis rectify: one camera's raw image (or a stereo pair's two) through its composed map
// (distortion correction + epipolar rectification [+ infrared-to-visible registration]) or the
// paper's elliptical correction, via the fixed-point table of fpga/remap.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <stdexcept>

#include "command.hpp"
#include "thermovis/fpga/fixed_map.hpp"
#include "thermovis/fpga/quarter_table.hpp"
#include "thermovis/fpga/remap.hpp"
#include "thermovis/fpga/table_export.hpp"
#include "thermovis/rectify/elliptical.hpp"
#include "thermovis/rectify/rig_rectification.hpp"
#include "thermovis/rectify/synthetic_view.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace {

namespace cam = thermovis::camera;
namespace rect = thermovis::rectify;
namespace fpga = thermovis::fpga;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string rig;
  std::string camera;  // mono
  std::string pair;    // stereo: visible | infrared
  std::string in, out;
  std::string left, right, out_left, out_right;
  std::string model = "taylor";  // taylor | elliptical
  std::string projection = "equirectangular";
  int width = 0;
  double registration_distance_m = 0.0;
  bool onto_visible = false;
  bool quarter = false;
  bool reference = false;
  bool checkerboard = false;
  std::string export_table;
  bool json = false;
};

// One camera to process: its map from output pixels to raw pixels and what the map is.
struct Job {
  const cam::RigCamera* camera = nullptr;
  std::string input, output, table_path;
  cv::Mat map;                            // CV_32FC2
  Eigen::Isometry3d T_ref_pattern;        // frame the synthetic checkerboard is aligned with
  nlohmann::json description;             // grid / model figures
  std::optional<double> parallax_offset;  // infrared registered: offset from its visible eye, m
  double grid_f = 0.0;                    // px per rad of the output grid (for parallax figures)
  int field_row = 0;                      // output row through the field's centre
  double map_ms = 0.0;
};

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

const cam::StereoPair& pair_of(const cam::Rig& rig, const std::string& name) {
  if (name == "visible") return rig.visible;
  if (name == "infrared") return rig.infrared;
  throw std::invalid_argument("unknown pair '" + name + "' (expected visible or infrared)");
}

nlohmann::json grid_json(const cam::RectifiedCamera& grid) {
  const auto& g = grid.intrinsics();
  return {{"projection", grid.name()},
          {"width", g.width},
          {"height", g.height},
          {"f_px_per_rad", g.f},
          {"grid_hfov_deg", grid.horizontal_field() * 180.0 / M_PI}};
}

cam::RectifiedProjection parse_projection(const std::string& name) {
  if (name == "equirectangular") return cam::RectifiedProjection::equirectangular;
  if (name == "cylindrical") return cam::RectifiedProjection::cylindrical;
  throw std::invalid_argument("unknown projection '" + name +
                              "' (expected equirectangular or cylindrical)");
}

// The Taylor-model maps of `names` (one or both eyes of a pair) on the pair's rectified grid, or
// on the visible grid of their side when registering infrared onto visible.
std::vector<Job> taylor_jobs(const cam::Rig& rig, const Options& opt,
                             const std::vector<std::string>& names) {
  std::vector<Job> jobs;
  for (const std::string& name : names) {
    const cam::RigCamera& camera = rig.camera(name);  // throws naming an unknown camera
    const bool is_visible = name == rig.visible.left || name == rig.visible.right;
    const bool is_infrared = name == rig.infrared.left || name == rig.infrared.right;
    if (!is_visible && !is_infrared) {
      throw std::invalid_argument("camera '" + name + "' belongs to no stereo pair of the rig");
    }
    if (opt.onto_visible && !is_infrared) {
      throw std::invalid_argument("--onto-visible registers an infrared camera; '" + name +
                                  "' is not one");
    }
    const cam::StereoPair& pair = (is_visible || opt.onto_visible) ? rig.visible : rig.infrared;
    const bool left_side = name == rig.visible.left || name == rig.infrared.left;
    cam::RectifiedIntrinsics intr =
        rect::default_pair_grid(rig, pair, parse_projection(opt.projection));
    if (opt.width > 0) {
      intr.width = opt.width;
      intr.cx = (opt.width - 1) / 2.0;
    }
    const rect::StereoGeometry g = rect::make_stereo_geometry(rig, pair, intr);
    Job job;
    job.camera = &camera;
    job.T_ref_pattern = left_side ? g.T_ref_left_rect : g.T_ref_right_rect;
    const auto t0 = Clock::now();
    job.map = rect::build_map(camera, job.T_ref_pattern, g.grid,
                              opt.onto_visible ? opt.registration_distance_m : 0.0);
    job.map_ms = ms_since(t0);
    job.grid_f = g.grid.intrinsics().f;
    job.field_row = static_cast<int>(std::lround(g.grid.intrinsics().cy));
    job.description = {{"model", "taylor"},
                       {"grid", grid_json(g.grid)},
                       {"pair", {pair.left, pair.right}},
                       {"baseline_m", g.baseline_m}};
    if (opt.onto_visible) {
      const std::string eye = left_side ? rig.visible.left : rig.visible.right;
      job.parallax_offset = rig.baseline_m(eye, name);
      job.description["registered_onto"] = eye;
      job.description["registration_distance_m"] = opt.registration_distance_m > 0.0
                                                       ? nlohmann::json(opt.registration_distance_m)
                                                       : nlohmann::json("infinity");
    }
    jobs.push_back(std::move(job));
  }
  return jobs;
}

std::vector<Job> elliptical_jobs(const cam::Rig& rig, const std::vector<std::string>& names) {
  std::vector<Job> jobs;
  for (const std::string& name : names) {
    const cam::RigCamera& camera = rig.camera(name);
    const auto* taylor = dynamic_cast<const cam::TaylorCamera*>(camera.model.get());
    if (taylor == nullptr) {
      throw std::invalid_argument("--model elliptical needs a Taylor camera; '" + name + "' is a " +
                                  camera.model->name() + " model");
    }
    Job job;
    job.camera = &camera;
    job.T_ref_pattern = camera.T_ref_cam;
    const auto t0 = Clock::now();
    const rect::EllipticalFit fit = rect::fit_elliptical_model(*taylor);
    job.map = rect::build_elliptical_map(fit.model);
    job.field_row = job.map.rows / 2;
    job.map_ms = ms_since(t0);
    job.description = {{"model", "elliptical"},
                       {"k1", fit.model.k1},
                       {"k2", fit.model.k2},
                       {"R", fit.model.R},
                       {"target_pinhole_f_px", fit.target_f_px},
                       {"fit_rms_px", fit.rms_px},
                       {"fit_max_px", fit.max_px}};
    jobs.push_back(std::move(job));
  }
  return jobs;
}

cv::Mat read_image(const std::string& path, const cam::RigCamera& camera) {
  if (!std::filesystem::exists(path)) {
    throw std::runtime_error("input image " + path + " does not exist");
  }
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw std::runtime_error("cannot read image " + path);
  if (image.type() != CV_8UC1 && image.type() != CV_8UC3 && image.type() != CV_16UC1) {
    throw std::runtime_error("image " + path + " has " + std::to_string(image.channels()) +
                             " channels of " + std::to_string(8 * image.elemSize1()) +
                             " bits; expected 8-bit grey, 8-bit BGR or 16-bit grey");
  }
  const cv::Size expected = camera.model->image_size();
  if (image.size() != expected) {
    throw std::runtime_error("image " + path + " is " + std::to_string(image.cols) + "x" +
                             std::to_string(image.rows) + " but camera " + camera.name + " is " +
                             std::to_string(expected.width) + "x" +
                             std::to_string(expected.height));
  }
  return image;
}

void write_image(const std::string& path, const cv::Mat& image) {
  const auto parent = std::filesystem::path(path).parent_path();
  if (!parent.empty() && !std::filesystem::is_directory(parent)) {
    throw std::runtime_error("cannot write " + path + ": folder " + parent.string() +
                             " does not exist");
  }
  bool ok = false;
  try {
    ok = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot write " + path + ": " + e.what());
  }
  if (!ok) throw std::runtime_error("cannot write " + path + " (unknown extension or no access)");
}

// `raw` is the input read beforehand (empty with --checkerboard: rendered here).
nlohmann::json run_job(const Job& job, cv::Mat raw, const Options& opt) {
  const cam::RigCamera& camera = *job.camera;
  if (opt.checkerboard) {
    // 5 deg squares aligned with the output grid: straight rows and columns after rectification.
    const int type = camera.band == "infrared" ? CV_16UC1 : CV_8UC3;
    raw = rect::render_pattern(camera, job.T_ref_pattern,
                               rect::angular_checkerboard(5.0 * M_PI / 180), type, 2);
    write_image(job.input, raw);
  }
  const fpga::FixedPointMap table = fpga::FixedPointMap::from_float(job.map, raw.size());
  const fpga::SymmetryReport symmetry = fpga::check_quarter_symmetry(table);
  std::optional<fpga::QuarterTable> quarter;
  if (opt.quarter) quarter = fpga::QuarterTable::from_map(table);  // throws with the reason

  const auto t0 = Clock::now();
  cv::Mat out;
  if (opt.reference) {
    out = quarter ? fpga::remap_reference(raw, *quarter) : fpga::remap_reference(raw, table);
  } else {
    out = fpga::FastRemapper(quarter ? quarter->expand() : table).remap(raw);
  }
  const double remap_ms = ms_since(t0);
  write_image(job.output, out);
  if (!job.table_path.empty()) {
    const auto format = std::filesystem::path(job.table_path).extension() == ".bin"
                            ? fpga::TableFormat::bin
                            : fpga::TableFormat::hex;
    if (quarter) {
      fpga::export_table(*quarter, job.table_path, format);
    } else {
      fpga::export_table(table, job.table_path, format);
    }
  }

  nlohmann::json j = job.description;
  j["camera"] = camera.name;
  j["input"] = job.input;
  j["output"] = job.output;
  j["input_size"] = {raw.cols, raw.rows};
  j["output_size"] = {out.cols, out.rows};
  j["field_kept_deg"] = rect::field_kept_deg(*camera.model, job.map, job.field_row);
  j["valid_fraction"] = double(table.valid_entries()) / double(table.size().area());
  j["float_map_bytes"] = job.map.total() * job.map.elemSize();
  j["table_format"] = "Q11.5 offsets from the source centre, 2 x int16 per entry";
  j["table_bytes"] = table.table_bytes();
  j["quarter_symmetric"] = symmetry.symmetric;
  j["symmetry_max_deviation_px"] = symmetry.max_deviation_px;
  if (symmetry.symmetric) {
    j["quarter_table_bytes"] = table.table_bytes() / 4;
  } else {
    j["quarter_table_bytes"] = nullptr;
    j["quarter_refused"] = symmetry.reason;
  }
  j["stored_table"] = quarter ? "quarter" : "full";
  if (!job.table_path.empty()) j["exported_table"] = job.table_path;
  j["remap_path"] = opt.reference ? "bit-exact reference" : "fast (Highway fixed-point kernel)";
  j["map_build_ms"] = job.map_ms;
  j["remap_ms"] = remap_ms;
  if (job.parallax_offset) {
    nlohmann::json parallax = nlohmann::json::object();
    for (double distance : {5.0, 10.0, 20.0, 50.0}) {
      parallax[std::to_string(static_cast<int>(distance)) + "m"] = rect::registration_parallax_px(
          job.grid_f, *job.parallax_offset, distance, opt.registration_distance_m);
    }
    j["camera_offset_m"] = *job.parallax_offset;
    j["registration_parallax_px"] = parallax;
  }
  return j;
}

std::string with_suffix(const std::string& path, const std::string& suffix) {
  const std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + suffix + p.extension().string())).string();
}

int run_rectify(const Options& opt) {
  if (opt.camera.empty() == opt.pair.empty()) {
    throw std::invalid_argument("give either --camera NAME or --pair visible|infrared");
  }
  if (opt.model != "taylor" && opt.model != "elliptical") {
    throw std::invalid_argument("unknown --model '" + opt.model +
                                "' (expected taylor or elliptical)");
  }
  if (opt.model == "elliptical" && opt.onto_visible) {
    throw std::invalid_argument(
        "--onto-visible needs --model taylor (the elliptical model "
        "corrects one camera's distortion only)");
  }
  const cam::Rig rig = thermovis::runtime::load_rig_or_default(opt.rig);

  std::vector<std::string> names;
  std::vector<std::pair<std::string, std::string>> files;  // input, output
  if (!opt.camera.empty()) {
    if (opt.in.empty() || opt.out.empty()) {
      throw std::invalid_argument("--camera needs --in RAW and --out RECTIFIED");
    }
    names = {opt.camera};
    files = {{opt.in, opt.out}};
  } else {
    const cam::StereoPair& pair = pair_of(rig, opt.pair);
    if (opt.left.empty() || opt.right.empty() || opt.out_left.empty() || opt.out_right.empty()) {
      throw std::invalid_argument("--pair needs --left, --right, --out-left and --out-right");
    }
    names = {pair.left, pair.right};
    files = {{opt.left, opt.out_left}, {opt.right, opt.out_right}};
  }
  // Inputs first: a bad image is reported before any map is computed.
  std::vector<cv::Mat> inputs(names.size());
  if (!opt.checkerboard) {
    for (std::size_t i = 0; i < names.size(); ++i) {
      inputs[i] = read_image(files[i].first, rig.camera(names[i]));
    }
  }
  std::vector<Job> jobs =
      opt.model == "taylor" ? taylor_jobs(rig, opt, names) : elliptical_jobs(rig, names);
  nlohmann::json results = nlohmann::json::array();
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    jobs[i].input = files[i].first;
    jobs[i].output = files[i].second;
    if (!opt.export_table.empty()) {
      jobs[i].table_path = jobs.size() == 1
                               ? opt.export_table
                               : with_suffix(opt.export_table, i == 0 ? ".left" : ".right");
    }
    results.push_back(run_job(jobs[i], inputs[i], opt));
  }
  if (opt.json) {
    nlohmann::json out = {{"rig", rig.name}, {"cameras", results}};
    if (!opt.pair.empty()) out["pair"] = opt.pair;
    std::cout << out.dump() << "\n";
    return 0;
  }
  std::cout << std::fixed << std::setprecision(1);
  for (const auto& r : results) {
    std::cout << r["camera"].get<std::string>() << " (" << r["model"].get<std::string>()
              << "): " << r["input"].get<std::string>() << " -> " << r["output"].get<std::string>()
              << " " << r["output_size"][0] << "x" << r["output_size"][1] << ", field kept "
              << r["field_kept_deg"].get<double>() << " deg, table "
              << r["table_bytes"].get<std::size_t>() << " B";
    if (r["quarter_table_bytes"].is_null()) {
      std::cout << " (not quarter symmetric)";
    } else {
      std::cout << ", quarter " << r["quarter_table_bytes"].get<std::size_t>() << " B";
    }
    std::cout << ", remap " << std::setprecision(2) << r["remap_ms"].get<double>() << " ms"
              << std::setprecision(1) << "\n";
    if (r.contains("registration_parallax_px")) {
      std::cout << "  registration parallax (px on the visible grid): ";
      for (const auto& [k, v] : r["registration_parallax_px"].items()) {
        std::cout << k << " " << v.get<double>() << "  ";
      }
      std::cout << "\n";
    }
  }
  return 0;
}

THERMOVIS_COMMAND(
    "rectify",
    "Rectify raw images through their composed map (Taylor + epipolar [+ registration]) or the "
    "paper's elliptical correction, via the fixed-point table",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--rig", opt->rig, "rig YAML (default: deploy/rigs/paper.yaml)");
      app.add_option("--camera", opt->camera, "one camera, e.g. visible.left");
      app.add_option("--in", opt->in, "raw image of --camera (8-bit grey/BGR or 16-bit grey)");
      app.add_option("--out", opt->out, "rectified image of --camera");
      app.add_option("--pair", opt->pair, "stereo: visible or infrared (writes both eyes)");
      app.add_option("--left", opt->left, "raw left image of --pair");
      app.add_option("--right", opt->right, "raw right image of --pair");
      app.add_option("--out-left", opt->out_left, "rectified left image");
      app.add_option("--out-right", opt->out_right, "rectified right image");
      app.add_option("--model", opt->model,
                     "taylor (rectified stereo grid, default) or elliptical (the paper's "
                     "Eq. 20-21 correction, same size as the raw image)");
      app.add_option("--projection", opt->projection,
                     "rectified grid: equirectangular (default) or cylindrical");
      app.add_option("--width", opt->width, "rectified grid columns (default: the pair's field)");
      app.add_flag("--onto-visible", opt->onto_visible,
                   "map an infrared camera onto the visible grid of its side (registration)");
      app.add_option("--registration-distance", opt->registration_distance_m,
                     "registration distance, m (default: infinity)");
      app.add_flag("--quarter", opt->quarter,
                   "store and use the quarter table (refused when the map is not symmetric)");
      app.add_flag("--reference", opt->reference,
                   "remap with the bit-exact fixed-point model instead of the fast path");
      app.add_flag("--checkerboard", opt->checkerboard,
                   "render a synthetic checkerboard through the camera model, WRITE it to "
                   "--in (--left/--right), then rectify it");
      app.add_option("--export-table", opt->export_table,
                     "write the table for RTL (.hex for $readmemh, .bin little-endian; "
                     "pairs get .left/.right before the extension)");
      app.add_flag("--json", opt->json, "print one JSON object");
      return [opt] { return run_rectify(*opt); };
    });

}  // namespace
