// thermovis calibrate: Taylor (OCamCalib) calibration from checkerboard images, mono or stereo.
//
// Mono:   thermovis calibrate --images DIR|FILES... --board 8x6 --square 32.5 [--out calib.yaml]
//         writes the camera YAML (runtime::taylor_to_yaml) and calib_results.txt beside it.
// Stereo: thermovis calibrate --left DIR|FILES... --right DIR|FILES... --board ... --square ...
//         [--out rig.yaml] writes a two-camera rig YAML.
// Corners can be given instead of images (--corners FILE, JSON; --save-corners writes the
// detected ones in the same format): {"image_size": [w, h], "views": [{"name": ..., "corners":
// [[x, y], ...]}]}, corners in board order (row-major over the --board grid, x = column,
// y = row, 0-based px; null for a corner not seen).
// rms_2d_px = sqrt(mean over all corners of the squared 2-D reprojection error), px.
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <regex>

#include "command.hpp"
#include "thermovis/calib/chessboard.hpp"
#include "thermovis/calib/stereo_calibration.hpp"
#include "thermovis/camera/ocam_io.hpp"
#include "thermovis/json/fields.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace {

namespace fs = std::filesystem;
namespace tcal = thermovis::calib;

struct Options {
  std::vector<std::string> images, left, right;
  std::string corners, save_corners, board, out, names = "left,right", band = "visible";
  double square_mm = 0.0;
  double pixel_pitch_um = 0.0;
  int degree = 4;
  bool json = false;
};

// Every image named by the arguments: folders are listed, files taken as they are.
std::vector<std::string> expand(const std::vector<std::string>& args) {
  std::vector<std::string> files;
  for (const auto& a : args) {
    if (fs::is_directory(a)) {
      for (auto& f : tcal::list_image_files(a)) files.push_back(std::move(f));
    } else if (fs::exists(a)) {
      files.push_back(a);
    } else {
      throw std::runtime_error("no such image or folder: " + a);
    }
  }
  return files;
}

struct ViewSet {
  std::vector<tcal::View> views;  // the images where the board was found
  std::vector<std::string> not_found;
  int total = 0;
  cv::Size image_size;
};

ViewSet detect(const std::vector<std::string>& files, cv::Size board) {
  ViewSet set;
  for (const auto& file : files) {
    const cv::Mat image = tcal::read_image(file);
    if (set.image_size.area() == 0) set.image_size = image.size();
    if (image.size() != set.image_size)
      throw std::runtime_error(file + ": image size " + std::to_string(image.cols) + "x" +
                               std::to_string(image.rows) + " differs from the first image's " +
                               std::to_string(set.image_size.width) + "x" +
                               std::to_string(set.image_size.height));
    ++set.total;
    const auto det = tcal::detect_chessboard(image, board);
    if (det.found)
      set.views.push_back({fs::path(file).filename().string(), det.corners});
    else
      set.not_found.push_back(fs::path(file).filename().string());
  }
  return set;
}

nlohmann::json corners_json(const ViewSet& set) {
  nlohmann::json j{{"image_size", {set.image_size.width, set.image_size.height}},
                   {"views", nlohmann::json::array()}};
  for (const auto& v : set.views) {
    nlohmann::json pts = nlohmann::json::array();
    for (const auto& p : v.corners)
      pts.push_back(p.allFinite() ? nlohmann::json{p.x(), p.y()} : nlohmann::json(nullptr));
    j["views"].push_back({{"name", v.name}, {"corners", pts}});
  }
  return j;
}

// One point of a corners list: [x, y], or null for a corner not found.
Eigen::Vector2d corner_point(const nlohmann::json& p, const std::string& where) {
  if (p.is_null()) return Eigen::Vector2d::Constant(std::nan(""));
  if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number())
    throw thermovis::json::JsonInputError(where + ": must be [x, y] or null, got " + p.dump());
  return {p[0].get<double>(), p[1].get<double>()};
}

ViewSet load_corners(const std::string& path, const tcal::BoardSpec& board) {
  namespace tj = thermovis::json;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open corners file " + path);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
  tj::require_object(j, path);
  ViewSet set;
  const auto size = j.find("image_size");
  if (size == j.end() || !size->is_array() || size->size() != 2 ||
      !(*size)[0].is_number_integer() || !(*size)[1].is_number_integer() ||
      (*size)[0].get<int>() <= 0 || (*size)[1].get<int>() <= 0) {
    throw tj::JsonInputError(path + ": field 'image_size' must be [width, height] in pixels, got " +
                             (size == j.end() ? std::string("nothing") : size->dump()));
  }
  set.image_size = {(*size)[0].get<int>(), (*size)[1].get<int>()};
  const auto views = j.find("views");
  if (views == j.end() || !views->is_array())
    throw tj::JsonInputError(path + ": field 'views' must be an array of views");
  for (std::size_t i = 0; i < views->size(); ++i) {
    const nlohmann::json& v = (*views)[i];
    const std::string where = path + " view " + std::to_string(i);
    tcal::View view;
    view.name = tj::field<std::string>(v, "name", where);
    const auto corners = v.find("corners");
    if (corners == v.end() || !corners->is_array())
      throw tj::JsonInputError(where + " (" + view.name + "): field 'corners' must be an array");
    for (std::size_t k = 0; k < corners->size(); ++k) {
      view.corners.push_back(
          corner_point((*corners)[k], where + " (" + view.name + ") corner " + std::to_string(k)));
    }
    if (static_cast<int>(view.corners.size()) != board.corner_count())
      throw tj::JsonInputError(where + " (" + view.name + ") has " +
                               std::to_string(view.corners.size()) + " corners, the board " +
                               std::to_string(board.corner_count()));
    set.views.push_back(std::move(view));
  }
  set.total = static_cast<int>(set.views.size());
  return set;
}

// Writes every file to a temporary name first and renames them all at the end, so a failure
// leaves nothing written half-way.
void write_all(const std::vector<std::pair<fs::path, std::string>>& files) {
  std::vector<fs::path> temps;
  for (const auto& [path, text] : files) {
    if (path.has_parent_path() && !fs::is_directory(path.parent_path()))
      throw std::runtime_error("output folder does not exist: " + path.parent_path().string());
    const fs::path tmp = path.string() + ".tmp";
    std::ofstream out(tmp);
    out << text;
    out.close();
    if (!out) {
      for (const auto& t : temps) fs::remove(t);
      fs::remove(tmp);
      throw std::runtime_error("cannot write " + path.string());
    }
    temps.push_back(tmp);
  }
  for (size_t i = 0; i < files.size(); ++i) fs::rename(temps[i], files[i].first);
}

std::string ocam_text(const thermovis::camera::TaylorIntrinsics& in) {
  std::ostringstream s;
  thermovis::camera::write_ocam_calib_results(in, s);
  return s.str();
}

nlohmann::json model_json(const thermovis::camera::TaylorIntrinsics& in) {
  return {{"image_size", {in.width, in.height}},
          {"centre_row_col", {in.xc, in.yc}},
          {"affine_cde", {in.c, in.d, in.e}},
          {"pol", in.pol},
          {"invpol", in.invpol}};
}

nlohmann::json mono_json(const tcal::TaylorCalibration& cal, const ViewSet& set) {
  nlohmann::json views = nlohmann::json::array();
  for (const auto& v : cal.views)
    views.push_back(
        {{"name", v.name}, {"used", v.used}, {"rms_2d_px", v.rms_2d_px}, {"max_px", v.max_px}});
  for (const auto& n : set.not_found)
    views.push_back({{"name", n}, {"used", false}, {"found", false}});
  return {{"rms_2d_px", cal.rms_2d_px},
          {"rms_definition", "sqrt(mean over all used corners of squared 2-D distance), px"},
          {"linear_rms_2d_px", cal.linear_rms_2d_px},
          {"images_used", cal.images_used},
          {"images_total", set.total},
          {"images_with_board", static_cast<int>(set.views.size())},
          {"corners_used", cal.corners_used},
          {"corners_rejected", cal.corners_rejected},
          {"model", model_json(cal.intrinsics)},
          {"views", views}};
}

void print_mono(const std::string& title, const tcal::TaylorCalibration& cal, const ViewSet& set) {
  const auto& in = cal.intrinsics;
  std::cout << title << ": " << cal.images_used << " of " << set.total << " images used ("
            << set.views.size() << " with the board found), " << cal.corners_used << " corners";
  if (cal.corners_rejected > 0) std::cout << " (" << cal.corners_rejected << " left out)";
  std::cout << "\n  rms_2d_px " << std::fixed << std::setprecision(4) << cal.rms_2d_px
            << "  (sqrt of the mean squared 2-D reprojection error over all corners; linear "
               "initialisation "
            << cal.linear_rms_2d_px << ")\n";
  std::cout << std::setprecision(6) << "  pol a0..a" << in.pol.size() - 1 << ":";
  for (double a : in.pol) std::cout << " " << std::defaultfloat << a;
  std::cout << std::fixed << std::setprecision(3) << "\n  centre (row, col) " << in.xc << ", "
            << in.yc << std::setprecision(6) << "   c d e " << in.c << " " << in.d << " " << in.e
            << "\n";
  for (const auto& v : cal.views)
    std::cout << "  " << std::left << std::setw(24) << v.name << std::right << std::setprecision(4)
              << " rms " << v.rms_2d_px << "  max " << v.max_px << (v.used ? "" : "  (dropped)")
              << "\n";
  for (const auto& n : set.not_found) std::cout << "  " << n << ": board not found\n";
}

int run_mono(const Options& opt, const tcal::BoardSpec& board) {
  ViewSet set = opt.corners.empty() ? detect(expand(opt.images), board.inner_corners)
                                    : load_corners(opt.corners, board);
  if (set.views.size() < 3) {
    std::string which;
    for (const auto& n : set.not_found) which += " " + n;
    throw std::runtime_error("the " + std::to_string(board.inner_corners.width) + "x" +
                             std::to_string(board.inner_corners.height) + " board was found in " +
                             std::to_string(set.views.size()) + " of " + std::to_string(set.total) +
                             " images; at least 3 are needed (check --board: inner corners, "
                             "columns x rows)" +
                             (which.empty() ? "" : "; not found in:" + which));
  }
  tcal::TaylorCalibrationOptions copt;
  copt.polynomial_degree = opt.degree;
  const auto cal = tcal::calibrate_taylor(set.views, board, set.image_size, copt);
  const fs::path out = opt.out.empty() ? fs::path("calib.yaml") : fs::path(opt.out);
  const fs::path ocam = out.parent_path() / "calib_results.txt";
  std::vector<std::pair<fs::path, std::string>> files{
      {out, thermovis::runtime::taylor_to_yaml(cal.intrinsics)}, {ocam, ocam_text(cal.intrinsics)}};
  if (!opt.save_corners.empty()) files.emplace_back(opt.save_corners, corners_json(set).dump(1));
  write_all(files);
  if (opt.json) {
    auto j = mono_json(cal, set);
    j["written"] = {out.string(), ocam.string()};
    std::cout << j.dump() << "\n";
  } else {
    print_mono("calibration", cal, set);
    std::cout << "wrote " << out.string() << " and " << ocam.string() << "\n";
  }
  return 0;
}

// The number in a file name (left07.jpg -> 7), to pair left and right images.
long pair_key(const std::string& name) {
  static const std::regex digits(R"((\d+)\D*$)");
  std::smatch m;
  if (!std::regex_search(name, m, digits))
    throw std::runtime_error("cannot pair " + name + ": its name has no number");
  return std::stol(m[1].str());
}

int run_stereo(const Options& opt, const tcal::BoardSpec& board) {
  const auto comma = opt.names.find(',');
  if (comma == std::string::npos)
    throw std::runtime_error("--names: expected LEFT,RIGHT, got '" + opt.names + "'");
  const std::string left_name = opt.names.substr(0, comma),
                    right_name = opt.names.substr(comma + 1);
  const ViewSet ls = detect(expand(opt.left), board.inner_corners);
  const ViewSet rs = detect(expand(opt.right), board.inner_corners);
  std::map<long, const tcal::View*> right_by_key;
  for (const auto& v : rs.views) right_by_key[pair_key(v.name)] = &v;
  std::vector<tcal::View> l, r;
  for (const auto& v : ls.views) {
    const auto it = right_by_key.find(pair_key(v.name));
    if (it == right_by_key.end()) continue;
    l.push_back(v);
    r.push_back(*it->second);
  }
  if (l.size() < 3)
    throw std::runtime_error("the board was found in both images of " + std::to_string(l.size()) +
                             " pairs (left " + std::to_string(ls.views.size()) + "/" +
                             std::to_string(ls.total) + ", right " +
                             std::to_string(rs.views.size()) + "/" + std::to_string(rs.total) +
                             "); at least 3 are needed (check --board and the file pairing)");
  tcal::TaylorCalibrationOptions copt;
  copt.polynomial_degree = opt.degree;
  const auto cal = tcal::calibrate_stereo(l, r, board, ls.image_size, rs.image_size, copt);

  thermovis::camera::Rig rig;
  rig.name = "calibrated";
  rig.reference = left_name;
  auto make = [&](const std::string& name, const thermovis::camera::TaylorIntrinsics& in,
                  const Eigen::Isometry3d& T_ref_cam_mm) {
    thermovis::camera::RigCamera cam;
    cam.name = name;
    cam.band = opt.band;
    cam.model = std::make_shared<thermovis::camera::TaylorCamera>(in);
    cam.pixel_pitch_um = opt.pixel_pitch_um;
    cam.T_ref_cam = T_ref_cam_mm;
    cam.T_ref_cam.translation() /= 1000.0;  // mm -> m
    return cam;
  };
  rig.cameras.push_back(make(left_name, cal.left_intrinsics, Eigen::Isometry3d::Identity()));
  rig.cameras.push_back(make(right_name, cal.right_intrinsics, cal.T_right_left.inverse()));
  rig.visible = {left_name, right_name};
  rig.infrared = {left_name, right_name};
  rig.notes.push_back("Calibrated by thermovis calibrate from " + std::to_string(cal.pairs_used) +
                      " checkerboard pairs (" + std::to_string(board.inner_corners.width) + "x" +
                      std::to_string(board.inner_corners.height) + " inner corners, " +
                      std::to_string(board.square_mm) + " mm); stereo rms_2d_px " +
                      std::to_string(cal.rms_2d_px) + ".");
  rig.notes.push_back(
      "One calibrated pair: both stereo entries name it. pixel_pitch_um is not "
      "measured by calibration (--pixel-pitch-um).");
  const fs::path out = opt.out.empty() ? fs::path("rig.yaml") : fs::path(opt.out);
  write_all({{out, thermovis::runtime::rig_to_yaml(rig)}});

  const Eigen::Vector3d t = cal.T_right_left.translation();
  const double angle_deg = Eigen::AngleAxisd(cal.T_right_left.rotation()).angle() * 180.0 / M_PI;
  if (opt.json) {
    nlohmann::json pairs = nlohmann::json::array();
    for (const auto& p : cal.pairs)
      pairs.push_back({{"left", p.left_name}, {"right", p.right_name}, {"rms_2d_px", p.rms_2d_px}});
    ViewSet lsu = ls, rsu = rs;
    nlohmann::json j{
        {"rms_2d_px", cal.rms_2d_px},
        {"rms_definition",
         "sqrt(mean over all corners of both images of used pairs of squared 2-D distance), px"},
        {"images_used", cal.pairs_used},
        {"images_total", std::min(ls.total, rs.total)},
        {"pairs_used", cal.pairs_used},
        {"corners_rejected", cal.corners_rejected},
        {"T_right_left", {{"translation_mm", {t.x(), t.y(), t.z()}}, {"rotation_deg", angle_deg}}},
        {"baseline_mm", t.norm()},
        {"left",
         {{"name", left_name},
          {"model", model_json(cal.left_intrinsics)},
          {"mono", mono_json(cal.left, lsu)}}},
        {"right",
         {{"name", right_name},
          {"model", model_json(cal.right_intrinsics)},
          {"mono", mono_json(cal.right, rsu)}}},
        {"pairs", pairs},
        {"written", {out.string()}}};
    std::cout << j.dump() << "\n";
  } else {
    print_mono("left (" + left_name + ")", cal.left, ls);
    print_mono("right (" + right_name + ")", cal.right, rs);
    std::cout << std::fixed << std::setprecision(4) << "stereo: " << cal.pairs_used
              << " pairs, rms_2d_px " << cal.rms_2d_px
              << " (over every corner of both images)\n  T_right_left: t = (" << t.x() << ", "
              << t.y() << ", " << t.z() << ") mm, rotation " << angle_deg << " deg, baseline "
              << t.norm() << " mm\n";
    for (const auto& p : cal.pairs)
      std::cout << "  " << p.left_name << " / " << p.right_name << " rms " << p.rms_2d_px << "\n";
    std::cout << "wrote " << out.string() << "\n";
  }
  return 0;
}

int run_calibrate(const Options& opt) {
  if (!(opt.square_mm > 0)) throw std::runtime_error("--square must be a positive size in mm");
  const tcal::BoardSpec board{tcal::parse_board_size(opt.board), opt.square_mm};
  const bool stereo = !opt.left.empty() || !opt.right.empty();
  if (stereo) {
    if (opt.left.empty() || opt.right.empty())
      throw std::runtime_error("stereo calibration needs both --left and --right");
    if (!opt.images.empty() || !opt.corners.empty())
      throw std::runtime_error("give either --images/--corners (mono) or --left/--right (stereo)");
    if (!(opt.pixel_pitch_um > 0))
      throw std::runtime_error("stereo calibration writes a rig: give --pixel-pitch-um (um)");
    return run_stereo(opt, board);
  }
  if (opt.images.empty() == opt.corners.empty())
    throw std::runtime_error("give --images DIR (or files) or --corners FILE");
  return run_mono(opt, board);
}

THERMOVIS_COMMAND(
    "calibrate",
    "Taylor (OCamCalib) calibration from checkerboard images: mono (--images) or stereo "
    "(--left/--right)",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--images", opt->images, "mono: image folder(s) or files")->expected(1, -1);
      app.add_option("--corners", opt->corners,
                     "mono: corners JSON instead of images (format: see --save-corners)");
      app.add_option("--left", opt->left, "stereo: left image folder(s) or files")->expected(1, -1);
      app.add_option("--right", opt->right,
                     "stereo: right image folder(s) or files (paired by the number in the name)")
          ->expected(1, -1);
      app.add_option("--board", opt->board, "inner corners COLUMNSxROWS, e.g. 8x6")->required();
      app.add_option("--square", opt->square_mm, "square size, mm")->required();
      app.add_option("--out", opt->out,
                     "output YAML (mono default calib.yaml, with calib_results.txt beside it; "
                     "stereo default rig.yaml)");
      app.add_option("--save-corners", opt->save_corners, "mono: also write the corners (JSON)");
      app.add_option("--degree", opt->degree, "polynomial degree (a0, a2..aN)")
          ->capture_default_str()
          ->check(CLI::Range(2, 6));
      app.add_option("--names", opt->names, "stereo: camera names LEFT,RIGHT")
          ->capture_default_str();
      app.add_option("--band", opt->band, "stereo: band of both cameras")
          ->capture_default_str()
          ->check(CLI::IsMember({"visible", "infrared"}));
      app.add_option("--pixel-pitch-um", opt->pixel_pitch_um,
                     "stereo: sensor pixel pitch written to the rig, um");
      app.add_flag("--json", opt->json, "print one JSON object");
      return [opt] { return run_calibrate(*opt); };
    });

}  // namespace
