// thermovis rig info: the geometry of a rig's cameras (field of view, distortion, baselines).
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "thermovis/camera/field.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace {

struct Options {
  std::string rig;
  bool json = false;
};

int run_rig_info(const Options& opt) {
  const auto rig = thermovis::runtime::load_rig_or_default(opt.rig);
  nlohmann::json out{
      {"rig", rig.name}, {"reference", rig.reference}, {"cameras", nlohmann::json::array()}};
  for (const auto& cam : rig.cameras) {
    const auto* taylor = dynamic_cast<const thermovis::camera::TaylorCamera*>(cam.model.get());
    if (taylor == nullptr) continue;
    const auto f = thermovis::camera::field_figures(*taylor);
    const Eigen::Vector3d t = cam.T_ref_cam.translation();
    out["cameras"].push_back({{"name", cam.name},
                              {"band", cam.band},
                              {"width", taylor->image_size().width},
                              {"height", taylor->image_size().height},
                              {"hfov_deg", f.horizontal_deg},
                              {"vfov_deg", f.vertical_deg},
                              {"dfov_deg", f.diagonal_deg},
                              {"corner_distortion_pct", 100.0 * f.corner_distortion},
                              {"corner_angle_deg", f.corner_angle_deg},
                              {"focal_px", f.paraxial_focal_px},
                              {"focal_mm", f.paraxial_focal_px * cam.pixel_pitch_um / 1000.0},
                              {"invpol_degree", taylor->intrinsics().invpol.size() - 1},
                              {"invpol_max_error_px", f.invpol_max_error_px},
                              {"position_m", {t.x(), t.y(), t.z()}}});
  }
  out["baselines_m"] = {{"visible", rig.baseline_m(rig.visible.left, rig.visible.right)},
                        {"infrared", rig.baseline_m(rig.infrared.left, rig.infrared.right)}};
  if (opt.json) {
    std::cout << out.dump() << "\n";
    return 0;
  }
  std::cout << "rig " << rig.name << " (reference frame: " << rig.reference << ")\n";
  std::cout << std::left << std::setw(16) << "camera" << std::right << std::setw(11) << "size"
            << std::setw(9) << "HFOV" << std::setw(9) << "VFOV" << std::setw(9) << "DFOV"
            << std::setw(12) << "corner dist" << std::setw(10) << "f (mm)" << std::setw(14)
            << "invpol err px"
            << "\n";
  std::cout << std::fixed;
  for (const auto& c : out["cameras"]) {
    std::cout << std::left << std::setw(16) << c["name"].get<std::string>() << std::right
              << std::setw(11)
              << (std::to_string(c["width"].get<int>()) + "x" +
                  std::to_string(c["height"].get<int>()))
              << std::setprecision(1) << std::setw(8) << c["hfov_deg"].get<double>() << "\u00b0"
              << std::setw(8) << c["vfov_deg"].get<double>() << "\u00b0" << std::setw(8)
              << c["dfov_deg"].get<double>() << "\u00b0" << std::setw(11)
              << c["corner_distortion_pct"].get<double>() << "%" << std::setprecision(2)
              << std::setw(10) << c["focal_mm"].get<double>() << std::setprecision(5)
              << std::setw(14) << c["invpol_max_error_px"].get<double>() << "\n";
  }
  std::cout << std::setprecision(4) << "baselines: visible "
            << out["baselines_m"]["visible"].get<double>() << " m, infrared "
            << out["baselines_m"]["infrared"].get<double>() << " m\n";
  for (const auto& note : rig.notes) std::cout << "note: " << note << "\n";
  return 0;
}

THERMOVIS_COMMAND("rig info", "Field of view, distortion and baselines of a rig's cameras",
                  [](CLI::App& app) -> thermovis::cli::Runner {
                    auto opt = std::make_shared<Options>();
                    app.add_option("--rig", opt->rig, "rig YAML (default: deploy/rigs/paper.yaml)");
                    app.add_flag("--json", opt->json, "print one JSON object");
                    return [opt] { return run_rig_info(*opt); };
                  });

}  // namespace
