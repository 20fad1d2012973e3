// thermovis report: docs/RESULTS.md, the project's measured tables, generated from its own
// benches and evaluations (never edited by hand). Each run is this executable with --json; its
// output is kept as JSON lines in a runs folder (runs.json names every command and the machine),
// and the tables are formatted from that folder, so `--from DIR` re-formats saved runs without
// measuring again (and a test checks the formatting on canned rows).
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "command.hpp"
#include "thermovis/metrics/vifb_metrics.hpp"

#ifndef THERMOVIS_REPORT_PIPELINE
#define THERMOVIS_REPORT_PIPELINE 0
#endif

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct Options {
  std::string out = "docs/RESULTS.md";
  std::string runs;  // where the raw JSON of each run is kept (default: a temporary folder)
  std::string from;  // format saved runs instead of measuring
  std::string data;  // test data root (default: $THERMOVIS_TEST_DATA or ../shared/data)
  bool quick = false;
  bool no_pipeline = false;
  bool no_lab = false;
};

// One measurement: `thermovis <args>` printing JSON lines. `kind` picks its table; runs of one
// kind (the calibration sets) share a table, one row each, labelled `label`.
struct Run {
  std::string kind, label;
  std::vector<std::string> args;
  std::string shown;  // the command as the report prints it, when not `thermovis <args>`
};

std::string join(const std::vector<std::string>& args) {
  std::string s;
  for (const auto& a : args) s += (s.empty() ? "" : " ") + a;
  return s;
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// The measurements, with their parameters. --quick: few trials, fewer methods and sets, no
// pipeline (a check that the report works, not figures to quote).
std::vector<Run> plan(const Options& opt, const fs::path& data, const fs::path& scratch) {
  const std::string d = data.string();
  const bool q = opt.quick;
  std::vector<Run> runs;
  runs.push_back({"rig", "", {"rig", "info", "--json"}, ""});
  // Table 6 over three seeds of ten trials each, on the pipeline's grid and on the full one.
  for (const std::string grid : {"0.5", "1.0"}) {
    if (q && grid != "0.5") continue;
    for (const std::string seed : {"1", "2", "3"}) {
      if (q && seed != "1") continue;
      runs.push_back({"ranging",
                      grid == "0.5" ? "Pipeline grid (--grid-scale 0.5, 417 px/rad)"
                                    : "Full visible grid (--grid-scale 1.0, 835 px/rad)",
                      {"bench", "ranging", "--trials", q ? "2" : "10", "--distances",
                       "5,10,15,20,25,30,40,60,80,100", "--mode", "all", "--seed", seed,
                       "--grid-scale", grid, "--bound", "--json"},
                      ""});
    }
  }
  runs.push_back({"match",
                  "",
                  {"match-eval", "--data", d + "/stereo/middlebury2014_quarter", "--methods",
                   q ? "ncc,orb" : "orb,akaze,sift,ncc,sgbm", "--repeat", q ? "1" : "3", "--json"},
                  ""});
  runs.push_back({"fusion",
                  "",
                  {"fuse-eval", "--dir", d + "/fusion/vifb", "--method",
                   q ? "fast" : "vsmwls,vsmwls-paper,fast", "--json"},
                  ""});
  // People on real annotated frames (eval frames: never trained on), each set and detector.
  struct DetectRun {
    std::string set, label;
    std::vector<std::string> flags;
  };
  std::vector<DetectRun> detect_runs{{"llvip_dev", "infrared classifier", {}}};
  if (!q) {
    detect_runs.push_back({"llvip_dev", "infrared warm blobs", {"--ir-detector", "warm-blob"}});
    detect_runs.push_back({"llvip_dev", "visible HOG", {"--band", "visible"}});
    detect_runs.push_back({"llvip_dev",
                           "visible Haar full body",
                           {"--band", "visible", "--visible-detector", "haar-fullbody"}});
    detect_runs.push_back({"llvip_dev",
                           "visible Haar upper body",
                           {"--band", "visible", "--visible-detector", "haar-upperbody"}});
    detect_runs.push_back({"llvip_dev", "fused (classifier + HOG)", {"--band", "fused"}});
    detect_runs.push_back({"hituav_train", "infrared classifier", {}});
    detect_runs.push_back({"hituav_train", "infrared warm blobs", {"--ir-detector", "warm-blob"}});
  }
  for (const auto& r : detect_runs) {
    std::vector<std::string> args{"detect-eval", "--dir", d + "/detect/" + r.set, "--json"};
    args.insert(args.end(), r.flags.begin(), r.flags.end());
    runs.push_back({"detection", r.set + ": " + r.label, args, ""});
  }
  // The simulated scenes on the pipeline grid (IoU 0.3: a far person's silhouette box is a few
  // pixels wide, one pixel off is IoU 0.5 lost).
  for (const std::string scene : {"paper", "night", "street"}) {
    if (q) continue;
    for (const bool blobs : {true, false}) {
      std::vector<std::string> args{"detect-eval", "--scene", scene, "--iou", "0.3", "--json"};
      if (blobs) args.insert(args.end(), {"--ir-detector", "warm-blob"});
      runs.push_back(
          {"detection",
           "simulated " + scene + " (IoU 0.3): infrared " + (blobs ? "warm blobs" : "classifier"),
           args, ""});
    }
  }
  // Obstacles from the dense stereo of each pair, against the simulator's truth.
  for (const std::string scene : {"street", "obstacles"}) {
    if (q && scene != "street") continue;
    runs.push_back({"obstacles", scene, {"bench", "obstacles", "--scene", scene, "--json"}, ""});
  }
  // At night (the visible pair dark): the infrared pair alone.
  if (!q) {
    runs.push_back(
        {"obstacles",
         "obstacles_night",
         {"bench", "obstacles", "--scene", "obstacles_night", "--band", "infrared", "--json"},
         ""});
  }
  // Board inner corners (columns x rows) and square size of each set: ../shared/data/calib.
  struct Set {
    std::string name, board, square;
  };
  std::vector<Set> sets{{"fisheye1", "8x6", "32.5"}};
  if (!q) {
    sets.push_back({"vmrimage", "6x7", "30"});
    sets.push_back({"ladybug", "5x8", "30"});
    sets.push_back({"miniomni", "7x11", "30"});
    sets.push_back({"kaidanomni", "7x11", "30"});
  }
  for (const auto& s : sets) {
    runs.push_back(
        {"calibration",
         s.name,
         {"calibrate", "--images", d + "/calib/ocamcalib_" + s.name + "/images", "--board", s.board,
          "--square", s.square, "--out", (scratch / (s.name + ".yaml")).string(), "--json"},
         ""});
  }
  if (!q) {
    // The stereo pairs share one folder: left*.jpg and right*.jpg, paired by their numbers.
    const fs::path images = data / "calib/opencv_stereo/images";
    std::vector<std::string> left, right;
    if (fs::is_directory(images)) {
      for (const auto& e : fs::directory_iterator(images)) {
        const std::string name = e.path().filename().string();
        if (name.rfind("left", 0) == 0) left.push_back(e.path().string());
        if (name.rfind("right", 0) == 0) right.push_back(e.path().string());
      }
    }
    std::sort(left.begin(), left.end());
    std::sort(right.begin(), right.end());
    Run stereo{"calibration",
               "opencv_stereo (stereo)",
               {"calibrate", "--left"},
               "thermovis calibrate --left " + images.string() + "/left*.jpg --right " +
                   images.string() +
                   "/right*.jpg --board 9x6 --square 25 --pixel-pitch-um 6 "
                   "--out rig.yaml --json"};
    stereo.args.insert(stereo.args.end(), left.begin(), left.end());
    stereo.args.push_back("--right");
    stereo.args.insert(stereo.args.end(), right.begin(), right.end());
    for (const char* a : {"--board", "9x6", "--square", "25", "--pixel-pitch-um", "6", "--json"})
      stereo.args.emplace_back(a);
    stereo.args.push_back("--out");
    stereo.args.push_back((scratch / "stereo.yaml").string());
    runs.push_back(stereo);
  }
  // The pipeline commands exist only in a build with DDS (services/thermovis/CMakeLists.txt).
  if (!q && !opt.no_pipeline && THERMOVIS_REPORT_PIPELINE) {
    runs.push_back(
        {"pipeline", "", {"bench", "pipeline", "--seconds", "20", "--warmup", "5", "--json"}, ""});
  }
  // The lab makes network namespaces: root only.
  if (!q && !opt.no_lab && THERMOVIS_REPORT_PIPELINE && ::geteuid() == 0) {
    const std::vector<std::vector<std::string>> lab_runs{
        {"--frames", "plain", "--rate", "5"},
        {"--frames", "plain", "--rate", "25"},
        {"--frames", "packed", "--rate", "25"},
        {"--frames", "packed", "--rate", "25", "--link-rate", "1gbit"},
        {"--frames", "packed", "--rate", "50"},
        {"--frames", "packed", "--rate", "50", "--link-rate", "1gbit"}};
    for (const auto& extra : lab_runs) {
      std::vector<std::string> args{"bench", "lab", "--seconds", "20", "--warmup", "10", "--json"};
      args.insert(args.end(), extra.begin(), extra.end());
      runs.push_back({"lab", "", args, ""});
    }
  }
  return runs;
}

// This executable with `args`; its stdout (stderr passes through, as progress).
std::string run_capture(const std::vector<std::string>& args) {
  std::string cmd = shell_quote(fs::read_symlink("/proc/self/exe").string());
  for (const auto& a : args) cmd += " " + shell_quote(a);
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) throw std::runtime_error("cannot start: thermovis " + join(args));
  std::string out;
  std::array<char, 4096> buf{};
  size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) out.append(buf.data(), n);
  const int status = pclose(pipe);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error("`thermovis " + join(args) + "` failed (exit status " +
                             std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
  }
  return out;
}

json machine_json() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string cpu = "unknown", line;
  int cores = 0;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("processor", 0) == 0) ++cores;
    if (line.rfind("model name", 0) == 0 && cpu == "unknown") {
      cpu = line.substr(line.find(':') + 2);
    }
  }
  double load = 0;
  std::ifstream("/proc/loadavg") >> load;
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  return {{"cpu", cpu}, {"cores", cores}, {"date", date}, {"load_average", load}};
}

void write_file(const fs::path& path, const std::string& text) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream f(tmp);
    f << text;
    if (!f) throw std::runtime_error("cannot write " + tmp.string());
  }
  fs::rename(tmp, path);
}

// ------------------------------------------------------------------------------ formatting
std::string fixed(const json& v, int decimals) {
  if (v.is_null()) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(decimals) << v.get<double>();
  return s.str();
}

std::string percent(const json& v, int decimals) {
  return v.is_null() ? "-" : fixed(100.0 * v.get<double>(), decimals) + " %";
}

std::string table_row(const std::vector<std::string>& cells) {
  std::string s = "|";
  for (const auto& c : cells) s += " " + c + " |";
  return s + "\n";
}

std::string table_head(const std::vector<std::string>& cells) {
  std::string s = table_row(cells) + "|";
  for (size_t i = 0; i < cells.size(); ++i) s += "---|";
  return s + "\n";
}

// The rows of `values` in first-seen order.
template <typename T>
void add_once(std::vector<T>& values, const T& v) {
  if (std::find(values.begin(), values.end(), v) == values.end()) values.push_back(v);
}

std::string rig_tables(const std::vector<json>& rows) {
  const json& r = rows.at(0);
  std::string s = table_head({"camera", "band", "size", "HFOV", "VFOV", "corner distortion",
                              "focal length", "position in the rig (m)"});
  for (const auto& c : r.at("cameras")) {
    const auto& p = c.at("position_m");
    s += table_row({c.at("name").get<std::string>(), c.at("band").get<std::string>(),
                    std::to_string(c.at("width").get<int>()) + " x " +
                        std::to_string(c.at("height").get<int>()),
                    fixed(c.at("hfov_deg"), 1) + " deg", fixed(c.at("vfov_deg"), 1) + " deg",
                    fixed(c.at("corner_distortion_pct"), 1) + " %",
                    fixed(c.at("focal_mm"), 2) + " mm (" + fixed(c.at("focal_px"), 1) + " px)",
                    fixed(p.at(0), 3) + ", " + fixed(p.at(1), 3) + ", " + fixed(p.at(2), 3)});
  }
  const auto& b = r.at("baselines_m");
  return s + "\nBaselines: visible " + fixed(b.at("visible"), 4) + " m, infrared " +
         fixed(b.at("infrared"), 4) + " m (rig `" + r.at("rig").get<std::string>() + "`).\n";
}

// Rows of several `bench ranging` runs (seeds) pooled per distance and mode: counts summed,
// means weighted by the people ranged, the largest error kept.
std::vector<json> pool_ranging(const std::vector<std::vector<json>>& runs) {
  std::vector<json> pooled;
  std::map<std::pair<double, std::string>, std::size_t> at;
  // abs, signed, sigma, within, bound (times its count), the bounds' count
  std::map<std::pair<double, std::string>, std::array<double, 6>> sums;
  for (const auto& rows : runs) {
    for (const auto& r : rows) {
      const std::pair<double, std::string> key{r.at("distance_m").get<double>(),
                                               r.at("mode").get<std::string>()};
      const int ranged = r.at("ranged").get<int>();
      if (!at.count(key)) {
        at[key] = pooled.size();
        pooled.push_back(r);
        pooled.back()["ranged"] = 0;
        pooled.back()["trials"] = 0;
        pooled.back()["max_abs_error_m"] = nullptr;
        sums[key] = {0, 0, 0, 0, 0, 0};
      }
      json& p = pooled[at[key]];
      if (r.contains("bounds")) {
        sums[key][4] += r.at("bounds").get<int>() * r.at("bound_mean_abs_m").get<double>();
        sums[key][5] += r.at("bounds").get<int>();
      }
      p["ranged"] = p["ranged"].get<int>() + ranged;
      p["trials"] = p["trials"].get<int>() + r.at("trials").get<int>();
      if (ranged == 0) continue;
      auto& sum = sums[key];
      sum[0] += ranged * r.at("mean_abs_error_m").get<double>();
      sum[1] += ranged * r.at("mean_signed_error_m").get<double>();
      sum[2] += ranged * r.at("mean_sigma_m").get<double>();
      sum[3] += ranged * r.at("within_1_sigma").get<double>();
      const double max = r.at("max_abs_error_m").get<double>();
      if (p["max_abs_error_m"].is_null() || max > p["max_abs_error_m"].get<double>())
        p["max_abs_error_m"] = max;
    }
  }
  for (auto& [key, index] : at) {
    json& p = pooled[index];
    const int n = p["ranged"].get<int>();
    const auto& sum = sums[key];
    const auto mean = [&](double v) { return n > 0 ? json(v / n) : json(nullptr); };
    p["mean_abs_error_m"] = mean(sum[0]);
    p["mean_signed_error_m"] = mean(sum[1]);
    p["mean_sigma_m"] = mean(sum[2]);
    p["within_1_sigma"] = mean(sum[3]);
    if (sum[5] > 0) {
      p["bound_mean_abs_m"] = sum[4] / sum[5];
      p["bounds"] = static_cast<int>(sum[5]);
    } else {
      p.erase("bound_mean_abs_m");
      p.erase("bounds");
    }
  }
  return pooled;
}

std::string ranging_tables(const std::vector<json>& rows) {
  std::vector<double> distances;
  std::vector<std::string> modes;
  std::map<std::pair<double, std::string>, json> cell;
  for (const auto& r : rows) {
    const double d = r.at("distance_m").get<double>();
    const std::string m = r.at("mode").get<std::string>();
    add_once(distances, d);
    add_once(modes, m);
    cell[{d, m}] = r;
  }
  std::vector<std::string> head{"m"}, head2{"m"};
  for (const auto& m : modes) {
    head.push_back(m);
    head2.push_back(m);
  }
  std::string s =
      "Mean / max absolute error (m) against the true distance of the person's centre, ranged "
      "of trials, the paper's Table 6 in brackets:\n\n" +
      table_head(head);
  std::string s2 =
      "\nSigned mean error (bias, m), mean one-sigma uncertainty (m), share of errors within "
      "one sigma:\n\n" +
      table_head(head2);
  for (double d : distances) {
    std::vector<std::string> line{fixed(d, 0)}, line2{fixed(d, 0)};
    for (const auto& m : modes) {
      const auto it = cell.find({d, m});
      if (it == cell.end()) {
        line.push_back("");
        line2.push_back("");
        continue;
      }
      const json& r = it->second;
      const std::string ranged = std::to_string(r.at("ranged").get<int>()) + "/" +
                                 std::to_string(r.at("trials").get<int>());
      const std::string errors =
          r.at("mean_abs_error_m").is_null()
              ? "-"
              : fixed(r.at("mean_abs_error_m"), 3) + " / " + fixed(r.at("max_abs_error_m"), 3);
      line.push_back(errors + ", " + ranged + " (" + fixed(r.at("paper_abs_error_m"), 2) + ")");
      line2.push_back(fixed(r.at("mean_signed_error_m"), 3) + ", " +
                      fixed(r.at("mean_sigma_m"), 3) + ", " + percent(r.at("within_1_sigma"), 0));
    }
    s += table_row(line);
    s2 += table_row(line2);
  }
  // The share within one sigma over every distance of a mode: a calibrated sigma gives 68 %,
  // which n trials measure to +-100 sqrt(0.68 0.32 / n) % (one binomial sigma).
  std::vector<std::string> all{"all"};
  for (const auto& m : modes) {
    double within = 0;
    int n = 0;
    for (double d : distances) {
      const auto it = cell.find({d, m});
      if (it == cell.end() || it->second.at("within_1_sigma").is_null()) continue;
      const int ranged = it->second.at("ranged").get<int>();
      within += ranged * it->second.at("within_1_sigma").get<double>();
      n += ranged;
    }
    all.push_back(n > 0 ? percent(within / n, 0) + " of " + std::to_string(n) + " (+-" +
                              fixed(100.0 * std::sqrt(0.68 * 0.32 / n), 1) + " %)"
                        : "-");
  }
  s2 += table_row(all) +
        "\nA calibrated sigma puts 68 % of the errors within one sigma; over the 30 trials of a "
        "cell that share varies by +-8.5 % (one binomial sigma), over a whole column by the "
        "figure in its last row.\n";
  // The same errors as disparity (Eq. 2: a range error of e m at L is e f B / L^2 px), beside
  // what Table 6 asks of the pixels.
  // One row per distance, one cell per mode: `text` of the cell's row, "" where it gives none.
  const auto cell_rows = [&](const std::function<std::string(const json&)>& text) {
    std::string out;
    for (double d : distances) {
      std::vector<std::string> line{fixed(d, 0)};
      for (const auto& m : modes) {
        const auto it = cell.find({d, m});
        line.push_back(it == cell.end() ? std::string() : text(it->second));
      }
      out += table_row(line);
    }
    return out;
  };
  std::string s3 =
      "\nMean absolute error as disparity (px, by Eq. 2 at the pair's focal length and "
      "baseline): ours / the paper's Table 6:\n\n" +
      table_head(head) + cell_rows([](const json& r) {
        const double per_px = 10.0 * r.at("eq2_error_at_0.1px_m").get<double>();
        if (!(per_px > 0)) return std::string();
        const json& ours = r.at("mean_abs_error_m");
        const json& paper = r.at("paper_abs_error_m");
        return (ours.is_null() ? std::string("-") : fixed(ours.get<double>() / per_px, 3)) + " / " +
               (paper.is_null() ? std::string("-") : fixed(paper.get<double>() / per_px, 3));
      });
  // --bound: the least mean |error| the noise of the target's pixels allows.
  std::string s4;
  bool bounded = false;
  for (const auto& [key, r] : cell) bounded = bounded || r.contains("bound_mean_abs_m");
  if (bounded) {
    s4 = "\nThe least mean absolute error (m) the noise of each person's pixels allows (`--bound`: "
         "the Cramer-Rao bound of its silhouette's disparity on noise-free renders with the "
         "rendered noise, as the mean |error| of an unbiased estimate at it; fused: both pairs' "
         "bounds combined), beside ours and Table 6: ours / bound / paper:\n\n" +
         table_head(head) + cell_rows([](const json& r) {
           if (!r.contains("bound_mean_abs_m")) return std::string();
           return fixed(r.at("mean_abs_error_m"), 3) + " / " + fixed(r.at("bound_mean_abs_m"), 4) +
                  " / " + fixed(r.at("paper_abs_error_m"), 2);
         });
  }
  return s + s2 + s3 + s4;
}

std::string match_tables(const std::vector<json>& rows) {
  std::string s = table_head({"method", "pairs", "matches/pair", "within 1 px", "within 0.5 px",
                              "mean abs error of those within 1 px", "ms/pair"});
  std::string dense;
  for (const auto& r : rows) {
    if (r.contains("dense_method")) {  // a dense method's row: bad pixels against the truth
      dense += table_row({r.at("dense_method").get<std::string>(), percent(r.at("bad1"), 1),
                          percent(r.at("bad2"), 1), percent(r.at("valid"), 1),
                          percent(r.at("bad1_valid"), 1), fixed(r.at("ms_per_pair"), 1)});
      continue;
    }
    s += table_row({r.at("method").get<std::string>(), std::to_string(r.at("scenes").get<int>()),
                    fixed(r.at("matches_per_pair"), 0), percent(r.at("within_1px"), 1),
                    percent(r.at("within_half_px"), 1),
                    fixed(r.at("mean_abs_error_px_inliers"), 3) + " px",
                    fixed(r.at("ms_per_pair"), 1)});
  }
  if (!dense.empty()) {
    s += "\nDense disparity (the obstacle stage's methods), every pixel with a ground truth; one "
         "without a disparity counts as bad:\n\n" +
         table_head({"dense method", "bad-1", "bad-2", "pixels with a disparity", "bad-1 of those",
                     "ms/pair"}) +
         dense;
  }
  return s;
}

std::string fusion_tables(const std::vector<json>& rows) {
  namespace vm = thermovis::metrics;
  std::vector<std::string> head{"metric"};
  const json* vifb = nullptr;
  for (const auto& r : rows) {
    head.push_back(r.at("method").get<std::string>());
    if (vifb == nullptr && r.contains("vifb")) vifb = &r;
  }
  if (vifb != nullptr) head.push_back("VIFB's published " + vifb->at("method").get<std::string>());
  std::string s = std::to_string(rows.at(0).at("pairs").get<int>()) + " pairs, colour " +
                  rows.at(0).at("colour").get<std::string>() + "; " +
                  rows.at(0).at("protocol").get<std::string>() + ". Means over the pairs:\n\n" +
                  table_head(head);
  for (vm::Metric m : vm::all_metrics()) {
    const std::string name(vm::metric_name(m));
    std::vector<std::string> line{name + (vm::higher_is_better(m) ? "" : " (lower is better)")};
    for (const auto& r : rows) line.push_back(fixed(r.at("mean").at(name), 4));
    if (vifb != nullptr) line.push_back(fixed(vifb->at("vifb").at(name), 4));
    s += table_row(line);
  }
  std::vector<std::string> ms{"ms per pair"};
  for (const auto& r : rows) ms.push_back(fixed(r.at("ms_per_pair"), 1));
  if (vifb != nullptr) ms.push_back("");
  return s + table_row(ms);
}

// One row per set and detector: AP50 (VOC all-point), precision and recall at the detector's
// operating point, AP50 per person height, ms per image.
std::string detection_tables(const std::vector<std::pair<std::string, json>>& runs) {
  std::string s = table_head({"set: detector", "images", "persons", "AP50", "precision", "recall",
                              "AP50 <30 px", "AP50 30-80 px", "AP50 >80 px", "ms per image"});
  for (const auto& [label, r] : runs) {
    std::vector<std::string> line{label,
                                  std::to_string(r.at("images").get<int>()),
                                  std::to_string(r.at("persons").get<int>()),
                                  fixed(r.at("ap50"), 3),
                                  fixed(r.at("precision"), 3),
                                  fixed(r.at("recall"), 3)};
    for (const auto& bucket : r.at("by_height")) {
      line.push_back(bucket.at("persons").get<int>() > 0
                         ? fixed(bucket.at("ap50"), 3) + " (" +
                               std::to_string(bucket.at("persons").get<int>()) + ")"
                         : "-");
    }
    line.push_back(fixed(r.at("ms_per_image"), 1));
    s += table_row(line);
  }
  return s;
}

// One row per scene: found / in view and median relative error per distance band, recall to
// the bench's limit, false obstacles on the empty road, CPU per capture.
std::string obstacle_tables(const std::vector<std::pair<std::string, json>>& runs) {
  std::vector<std::string> head{"scene (band, method)"};
  for (const auto& d : runs.front().second.at("per_distance"))
    head.push_back(d.at("distance_m").get<std::string>() + " m");
  for (const char* h : {"recall", "false per 100 empty frames", "CPU ms per capture (p95)"})
    head.emplace_back(h);
  std::string s =
      "Per distance: found / in view, median |error| in % of the distance.\n\n" + table_head(head);
  for (const auto& [label, r] : runs) {
    std::vector<std::string> line{label + " (" + r.at("band").get<std::string>() + ", " +
                                  r.at("method").get<std::string>() + ")"};
    for (const auto& d : r.at("per_distance")) {
      const int truths = d.at("truths").get<int>();
      const int found = d.at("found").get<int>();
      line.push_back(std::to_string(found) + "/" + std::to_string(truths) +
                     (found > 0 ? ", " + fixed(d.at("median_rel_error_pct"), 1) + " %" : ""));
    }
    line.push_back(fixed(r.at("recall_pct"), 1) + " % to " + fixed(r.at("recall_up_to_m"), 0) +
                   " m");
    line.push_back(fixed(r.at("false_obstacles_per_100_frames"), 0));
    line.push_back(fixed(r.at("cpu_ms_median"), 1) + " (" + fixed(r.at("cpu_ms_p95"), 1) + ")");
    s += table_row(line);
  }
  return s;
}

std::string calibration_tables(const std::vector<std::pair<std::string, json>>& sets) {
  std::string s = table_head({"set", "images used", "corners used (left out)", "rms_2d_px",
                              "linear initialisation rms_2d_px", "a0", "centre (row, col)"});
  for (const auto& [label, r] : sets) {
    // A stereo run reports both cameras' mono figures under left/right and its own rms.
    const bool stereo = r.contains("left");
    const json& mono = stereo ? r.at("left").at("mono") : r;
    const json& model = mono.at("model");
    const std::string used = std::to_string(r.at("images_used").get<int>()) + "/" +
                             std::to_string(r.at("images_total").get<int>()) +
                             (stereo ? " pairs" : "");
    std::string rms = fixed(r.at("rms_2d_px"), 4);
    if (stereo) {
      rms += " (mono " + fixed(r.at("left").at("mono").at("rms_2d_px"), 4) + " / " +
             fixed(r.at("right").at("mono").at("rms_2d_px"), 4) + "; baseline " +
             fixed(r.at("baseline_mm"), 1) + " mm)";
    }
    s += table_row({label, used,
                    std::to_string(mono.at("corners_used").get<int>()) + " (" +
                        std::to_string(r.at("corners_rejected").get<int>()) + ")",
                    rms, fixed(mono.at("linear_rms_2d_px"), 4),
                    fixed(model.at("pol").at(0), 2) + (stereo ? " (left)" : ""),
                    fixed(model.at("centre_row_col").at(0), 1) + ", " +
                        fixed(model.at("centre_row_col").at(1), 1)});
  }
  return s;
}

std::string pipeline_tables(const std::vector<json>& rows) {
  const json& r = rows.at(0);
  // A stage's own time, and when its output was ready after the capture (p50): the gaps between
  // the stages' outputs are the transport and the waits for a core.
  std::string s =
      table_head({"", "p50 (ms)", "p99 (ms)", "max (ms)", "output after the capture, p50 (ms)"});
  s += table_row({"capture to range", fixed(r.at("p50_ms"), 1), fixed(r.at("p99_ms"), 1),
                  fixed(r.at("max_ms"), 1), fixed(r.at("p50_ms"), 1)});
  for (const auto& [stage, t] : r.at("stages").items()) {
    s += table_row({"stage " + stage, fixed(t.at("p50_ms"), 1), fixed(t.at("p99_ms"), 1),
                    fixed(t.at("max_ms"), 1),
                    t.contains("done_p50_ms") ? fixed(t.at("done_p50_ms"), 1) : "-"});
  }
  s += "\n" + std::to_string(r.at("frames").get<long>()) + " frames reached the output in " +
       fixed(r.at("seconds"), 0) + " s; over the deadline " +
       std::to_string(r.at("over_deadline").get<long>()) + ", dropped " +
       std::to_string(r.at("dropped").get<long>()) + ", DEADLINE QoS misses " +
       std::to_string(r.at("deadline_misses").get<long>()) + ", bad inputs " +
       std::to_string(r.at("bad_inputs").get<long>()) + ", restarts " +
       std::to_string(r.at("restarts").get<long>()) +
       ". Ranging against the simulated truth: " + std::to_string(r.at("ranges").get<long>()) +
       " ranges, " + std::to_string(r.at("ranges_on_target").get<long>()) +
       " on a target, mean |error| " + fixed(r.at("mean_abs_error_m"), 3) + " m (" +
       percent(r.at("mean_abs_relative_error"), 2) + "), p95 " + fixed(r.at("p95_abs_error_m"), 3) +
       " m.";
  if (r.contains("host_stalls")) {
    // The machine's own stalls (bench pipeline's probe), and what of the tails fell in them.
    const json& h = r.at("host_stalls");
    const auto count = [&](const char* key) { return std::to_string(h.at(key).get<long>()); };
    s += " The machine's CPUs stopped " + count("over_5ms") + " times for 5 ms or more (" +
         count("over_10ms") + " for 10 ms or more, longest " + fixed(h.at("max_ms"), 1) +
         " ms, seen by a probe at " + h.at("probe").get<std::string>() + " on each CPU); " +
         count("over_deadline_in_stalls") + " of the " +
         std::to_string(r.at("over_deadline").get<long>()) + " frames over the deadline and " +
         count("deadline_misses_in_stalls") + " of the " + count("deadline_misses") +
         " DEADLINE misses fell in one.";
  }
  s += "\n\n";
  s += table_head({"process", "CPU (% of one core)", "RSS (MB)", "scheduling"});
  for (const auto& [service, p] : r.at("processes").items()) {
    s += table_row({service, fixed(p.at("cpu_percent"), 0), fixed(p.at("rss_mb"), 0),
                    p.value("scheduling", std::string())});
  }
  return s;
}

// One row per `bench lab` run.
std::string lab_tables(const std::vector<std::vector<json>>& runs) {
  std::string s = table_head({"host b reads", "bridge (Hz)", "host a's link", "answered at c",
                              "capture -> c p50 (ms)", "p99 (ms)", "host a sent (Mbit/s)"});
  for (const auto& rows : runs) {
    const json& r = rows.at(0);
    const std::string link = r.at("link_rate").get<std::string>();
    s += table_row({r.at("frames").get<std::string>(), fixed(r.at("rate_hz"), 0),
                    link.empty() ? "veth" : link, percent(r.at("results_of_captures"), 1),
                    fixed(r.at("p50_ms"), 1), fixed(r.at("p99_ms"), 1),
                    fixed(r.at("link_mbit_s"), 0)});
  }
  return s;
}

struct Section {
  std::string kind, title;
};
const std::vector<Section> kSections{
    {"rig", "The rig's cameras"},
    {"ranging", "Ranging error per distance (the paper's Table 6) on the simulated rig"},
    {"match", "Stereo matching on Middlebury 2014 (quarter size)"},
    {"fusion", "Infrared/visible fusion on VIFB"},
    {"detection",
     "People on real annotated frames (the evaluation frames of each set, never trained on)"},
    {"obstacles", "Obstacles from dense stereo on the simulated rig"},
    {"calibration", "Taylor (OCamCalib) calibration of the sample sets (every image of a set)"},
    {"pipeline", "The whole pipeline (50 Hz, full-resolution simulated frames)"},
    {"lab",
     "The pipeline over three lab hosts (bridge and rectify-fuse on a, detect, match and range on "
     "b, the results' reader on c; paper scene)"}};

std::vector<json> read_rows(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file.string() + ": cannot read");
  std::vector<json> rows;
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    if (line.empty() || line.front() != '{') continue;  // progress text, not a row
    try {
      rows.push_back(json::parse(line));
    } catch (const json::exception& e) {
      throw std::runtime_error(file.string() + ":" + std::to_string(n) + ": not JSON: " + e.what());
    }
  }
  if (rows.empty()) throw std::runtime_error(file.string() + ": no JSON rows");
  return rows;
}

// RESULTS.md from a runs folder: runs.json (machine, mode, runs: kind, label, command, file)
// and one file of JSON lines per run.
std::string format_report(const fs::path& dir) {
  const fs::path index = dir / "runs.json";
  json meta;
  try {
    std::ifstream in(index);
    if (!in) throw std::runtime_error("cannot read");
    meta = json::parse(in);
  } catch (const std::exception& e) {
    throw std::runtime_error(index.string() + ": " + e.what());
  }
  std::ostringstream md;
  try {
    const json& m = meta.at("machine");
    const bool quick = meta.at("quick").get<bool>();
    md << "# Measured results\n\n"
       << "Generated by `" << meta.at("command").get<std::string>()
       << "`: do not edit by hand, run it again (from the repository root, after a build). "
       << "Every table names the command that measured it.\n\n"
       << "Machine: " << m.at("cpu").get<std::string>() << ", " << m.at("cores").get<int>()
       << " cores, load average " << fixed(m.at("load_average"), 1) << " at the start; "
       << m.at("date").get<std::string>() << ".\n";
    if (quick) {
      md << "\n**Quick mode**: few trials, two matching methods, the fast fusion only, one "
            "calibration set and no pipeline run. A check that the report works; quote the "
            "full report's figures (`thermovis report`).\n";
    }
  } catch (const json::exception& e) {
    throw std::runtime_error(index.string() + ": " + e.what());
  }
  for (const Section& section : kSections) {
    std::vector<std::pair<json, std::vector<json>>> runs;
    for (const auto& run : meta.at("runs")) {
      if (run.at("kind") == section.kind) {
        runs.emplace_back(run, read_rows(dir / run.at("file").get<std::string>()));
      }
    }
    if (runs.empty()) continue;
    md << "\n## " << section.title << "\n\n";
    for (const auto& [run, rows] : runs) md << "`" << run.at("command").get<std::string>() << "`\n";
    md << "\n";
    const fs::path first = dir / runs.front().first.at("file").get<std::string>();
    try {
      if (section.kind == "rig") md << rig_tables(runs.front().second);
      if (section.kind == "ranging") {
        // One table set per label (grid), the runs of a label (seeds) pooled.
        std::vector<std::string> labels;
        for (const auto& [run, rows] : runs) add_once(labels, run.at("label").get<std::string>());
        for (const auto& label : labels) {
          std::vector<std::vector<json>> of_label;
          for (const auto& [run, rows] : runs)
            if (run.at("label") == label) of_label.push_back(rows);
          if (!label.empty()) md << "\n### " << label << "\n\n";
          md << ranging_tables(pool_ranging(of_label));
        }
      }
      if (section.kind == "match") md << match_tables(runs.front().second);
      if (section.kind == "fusion") md << fusion_tables(runs.front().second);
      if (section.kind == "pipeline") md << pipeline_tables(runs.front().second);
      if (section.kind == "lab") {
        std::vector<std::vector<json>> all;
        for (const auto& [run, rows] : runs) all.push_back(rows);
        md << lab_tables(all);
      }
      if (section.kind == "detection" || section.kind == "obstacles") {
        std::vector<std::pair<std::string, json>> sets;
        for (const auto& [run, rows] : runs) sets.emplace_back(run.at("label"), rows.front());
        md << (section.kind == "detection" ? detection_tables(sets) : obstacle_tables(sets));
      }
      if (section.kind == "calibration") {
        std::vector<std::pair<std::string, json>> sets;
        for (const auto& [run, rows] : runs) sets.emplace_back(run.at("label"), rows.front());
        md << calibration_tables(sets);
      }
    } catch (const json::exception& e) {
      throw std::runtime_error(first.string() + " (" + section.kind + "): " + e.what());
    }
  }
  return md.str();
}

std::string default_data_root() {
  const char* env = std::getenv("THERMOVIS_TEST_DATA");
  return env != nullptr && *env != '\0' ? std::string(env) : std::string("../shared/data");
}

int run_report(const Options& opt) {
  if (!opt.from.empty()) {
    write_file(opt.out, format_report(opt.from));
    std::cout << "wrote " << opt.out << " from the runs in " << opt.from << "\n";
    return 0;
  }
  const fs::path data = opt.data.empty() ? default_data_root() : opt.data;
  if (!fs::is_directory(data)) {
    throw std::runtime_error("--data: no folder " + data.string() +
                             " (the shared test data; set THERMOVIS_TEST_DATA)");
  }
  const fs::path dir = opt.runs.empty() ? fs::temp_directory_path() /
                                              ("thermovis-report-" + std::to_string(getpid()))
                                        : fs::path(opt.runs);
  fs::create_directories(dir / "scratch");
  json meta{
      {"machine", machine_json()},
      {"quick", opt.quick},
      {"command", std::string("thermovis report") + (opt.quick ? " --quick" : "") +
                      (opt.no_pipeline ? " --no-pipeline" : "") + (opt.no_lab ? " --no-lab" : "")},
      {"runs", json::array()}};
  const auto runs = plan(opt, data, dir / "scratch");
  for (size_t i = 0; i < runs.size(); ++i) {
    const Run& run = runs[i];
    const std::string file = std::to_string(i) + "-" + run.kind + ".jsonl";
    std::cerr << "report: [" << i + 1 << "/" << runs.size() << "] thermovis " << join(run.args)
              << std::endl;
    const auto start = std::chrono::steady_clock::now();
    write_file(dir / file, run_capture(run.args));
    std::cerr << "report: done in "
              << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
              << " s" << std::endl;
    meta["runs"].push_back(
        {{"kind", run.kind},
         {"label", run.label},
         {"command", run.shown.empty() ? "thermovis " + join(run.args) : run.shown},
         {"file", file}});
  }
  write_file(dir / "runs.json", meta.dump(1) + "\n");
  write_file(opt.out, format_report(dir));
  std::cout << "wrote " << opt.out << " (the runs' raw JSON is in " << dir.string() << ")\n";
  return 0;
}

THERMOVIS_COMMAND(
    "report",
    "Run the benches and evaluations with --json and write their tables (docs/RESULTS.md)",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--out", opt->out, "Markdown file to write")->capture_default_str();
      app.add_flag("--quick", opt->quick,
                   "few trials, fewer methods and sets, no pipeline run (a check, minutes)");
      app.add_flag("--no-pipeline", opt->no_pipeline,
                   "leave out `thermovis bench pipeline` (it saturates the machine)");
      app.add_flag("--no-lab", opt->no_lab,
                   "leave out `thermovis bench lab` (it runs only as root: network namespaces)");
      app.add_option("--data", opt->data,
                     "test data root (default: $THERMOVIS_TEST_DATA, else ../shared/data)");
      app.add_option("--runs", opt->runs,
                     "folder to keep every run's raw JSON in, with runs.json (default: a "
                     "temporary folder)");
      app.add_option("--from", opt->from,
                     "format the runs saved in this folder (runs.json) instead of measuring");
      return [opt] { return run_report(*opt); };
    });

}  // namespace
