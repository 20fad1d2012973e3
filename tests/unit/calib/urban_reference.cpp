#include "urban_reference.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace thermovis::test {

UrbanReference load_urban_reference(const std::filesystem::path& set_folder,
                                    const std::string& method) {
  const auto path = set_folder / "reference" / "urban2015_results.json";
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  const auto all = nlohmann::json::parse(in);
  const auto& m = all.at("methods").at(method);
  UrbanReference ref;
  ref.method = method;
  const auto& inner = m.at("board").at("inner_corners");
  // Corner k = i * n_j + j sits at (Xt, Yt) = (i, j) * square: rows are i, columns j.
  ref.board.inner_corners = cv::Size(inner.at(1).get<int>(), inner.at(0).get<int>());
  ref.board.square_mm = m.at("board").at("dX_mm").get<double>();
  for (const auto& img : m.at("per_image")) {
    calib::View view;
    view.name = img.at("image").get<std::string>();
    const auto& rows = img.at("Xp_abs_row");
    const auto& cols = img.at("Yp_abs_col");
    for (size_t k = 0; k < rows.size(); ++k)
      view.corners.emplace_back(cols.at(k).get<double>() - 1.0, rows.at(k).get<double>() - 1.0);
    ref.images.push_back(view.name);
    ref.views.push_back(std::move(view));
  }
  const auto& model = m.at("ocam_model");
  auto& intr = ref.intrinsics;
  intr.width = static_cast<int>(model.at("width").get<double>());
  intr.height = static_cast<int>(model.at("height").get<double>());
  const bool swapped = method.rfind("urban_", 0) == 0;  // xc field = column there
  const double xf = model.at("xc_field").get<double>(), yf = model.at("yc_field").get<double>();
  intr.xc = (swapped ? yf : xf) - 1.0;
  intr.yc = (swapped ? xf : yf) - 1.0;
  intr.c = model.at("c").get<double>();
  intr.d = model.at("d").get<double>();
  intr.e = model.at("e").get<double>();
  intr.pol = model.at("ss").get<std::vector<double>>();
  ref.rms_2d_px = m.at("rms").get<double>() * (swapped ? std::sqrt(2.0) : 1.0);

  // Reproject the stored corners: p_ocam = [r1 r2 t] (Xt, Yt, 1); our camera frame is
  // (x, y, z) = (v, u, -w) of OCamCalib's.
  const camera::TaylorCamera cam(ref.intrinsics);
  const auto Xt = m.at("board").at("Xt_mm").get<std::vector<double>>();
  const auto Yt = m.at("board").at("Yt_mm").get<std::vector<double>>();
  double sum = 0.0;
  size_t count = 0;
  for (size_t i = 0; i < ref.views.size(); ++i) {
    const auto RR = m.at("per_image").at(i).at("RRfin_r1_r2_t");
    for (size_t k = 0; k < Xt.size(); ++k) {
      Eigen::Vector3d p;
      for (int a = 0; a < 3; ++a)
        p[a] = RR.at(a).at(0).get<double>() * Xt[k] + RR.at(a).at(1).get<double>() * Yt[k] +
               RR.at(a).at(2).get<double>();
      Eigen::Vector2d px;
      if (!cam.project(Eigen::Vector3d(p[1], p[0], -p[2]), px))
        throw std::runtime_error("reference corner not projectable in " + path.string());
      sum += (px - ref.views[i].corners[k]).squaredNorm();
      ++count;
    }
  }
  ref.unweighted_rms_2d_px = std::sqrt(sum / static_cast<double>(count));
  return ref;
}

namespace {

std::vector<Eigen::Vector2d> relabel(cv::Size grid, const std::vector<Eigen::Vector2d>& pts,
                                     bool transpose, bool flip_x, bool flip_y, cv::Size& out_grid) {
  out_grid = transpose ? cv::Size(grid.height, grid.width) : grid;
  std::vector<Eigen::Vector2d> out(pts.size());
  for (int r = 0; r < out_grid.height; ++r) {
    for (int c = 0; c < out_grid.width; ++c) {
      const int rr = flip_y ? out_grid.height - 1 - r : r;
      const int cc = flip_x ? out_grid.width - 1 - c : c;
      const int src_r = transpose ? cc : rr, src_c = transpose ? rr : cc;
      out[static_cast<size_t>(r * out_grid.width + c)] =
          pts[static_cast<size_t>(src_r * grid.width + src_c)];
    }
  }
  return out;
}

}  // namespace

GridAgreement compare_grids(cv::Size grid_a, const std::vector<Eigen::Vector2d>& a, cv::Size grid_b,
                            const std::vector<Eigen::Vector2d>& b) {
  GridAgreement best;
  best.median_px = best.max_px = std::numeric_limits<double>::infinity();
  for (bool transpose : {false, true}) {
    for (bool fx : {false, true}) {
      for (bool fy : {false, true}) {
        cv::Size g;
        const auto pa = relabel(grid_a, a, transpose, fx, fy, g);
        if (g != grid_b) continue;
        std::vector<double> d;
        size_t worst = 0;
        for (size_t k = 0; k < pa.size(); ++k) {
          if (!pa[k].allFinite()) continue;  // a corner the detector left out
          if (d.empty() || (pa[k] - b[k]).norm() > (pa[worst] - b[worst]).norm()) worst = k;
          d.push_back((pa[k] - b[k]).norm());
        }
        if (d.empty()) continue;
        GridAgreement here{0.0, (pa[worst] - b[worst]).norm(), 0.0, pa[worst], b[worst]};
        here.within_1px = static_cast<double>(std::count_if(d.begin(), d.end(),
                                                            [](double x) { return x <= 1.0; })) /
                          static_cast<double>(d.size());
        std::sort(d.begin(), d.end());
        if (d[d.size() / 2] < best.median_px) {
          best = here;
          best.median_px = d[d.size() / 2];
        }
      }
    }
  }
  return best;
}

}  // namespace thermovis::test
