#include "thermovis/runtime/rig_io.hpp"

#include <yaml-cpp/yaml.h>

#include <Eigen/SVD>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <queue>
#include <set>
#include <sstream>
#include <vector>

#include "thermovis/camera/rectified.hpp"
#include "thermovis/runtime/yaml_util.hpp"

namespace thermovis::runtime {
namespace {

using camera::Rig;
using camera::RigCamera;
using camera::TaylorIntrinsics;

TaylorIntrinsics taylor_from_node(const std::string& src, const YAML::Node& model,
                                  const std::string& ctx) {
  check_keys(src, model, ctx,
             {"type", "image_size", "centre_row_col", "affine_cde", "pol", "invpol"});
  const std::string type = as_string(src, require(src, model, ctx, "type"), ctx + ".type");
  if (type != "taylor") {
    throw ConfigError(where(src, model["type"]) + ": " + ctx + ".type: unknown model '" + type +
                      "' (known: taylor)");
  }
  TaylorIntrinsics in;
  const auto size = as_doubles(src, require(src, model, ctx, "image_size"), ctx + ".image_size", 2);
  // Checked as doubles: converting a huge value to int first would be undefined.
  for (const double side : size) {
    if (!(side >= 1 && side <= camera::kMaxImageSide) || side != std::floor(side)) {
      throw ConfigError(where(src, model["image_size"]) + ": " + ctx +
                        ".image_size: expected two whole numbers of pixels in 1.." +
                        std::to_string(camera::kMaxImageSide) + " [width, height]");
    }
  }
  in.width = static_cast<int>(size[0]);
  in.height = static_cast<int>(size[1]);
  const auto centre =
      as_doubles(src, require(src, model, ctx, "centre_row_col"), ctx + ".centre_row_col", 2);
  in.xc = centre[0];
  in.yc = centre[1];
  const auto cde = as_doubles(src, require(src, model, ctx, "affine_cde"), ctx + ".affine_cde", 3);
  in.c = cde[0];
  in.d = cde[1];
  in.e = cde[2];
  in.pol = as_doubles(src, require(src, model, ctx, "pol"), ctx + ".pol");
  if (model["invpol"]) in.invpol = as_doubles(src, model["invpol"], ctx + ".invpol");
  return in;
}

// The camera of a `model:` block; its constructor validates the values (and fits the inverse
// polynomial when none is given, once: the rig keeps this camera).
std::shared_ptr<camera::TaylorCamera> checked_camera(const std::string& src,
                                                     const YAML::Node& model,
                                                     const std::string& ctx) {
  TaylorIntrinsics in = taylor_from_node(src, model, ctx);
  try {
    return std::make_shared<camera::TaylorCamera>(std::move(in));
  } catch (const std::exception& e) {
    throw ConfigError(where(src, model) + ": " + ctx + ": " + e.what());
  }
}

void emit_taylor(YAML::Emitter& out, const TaylorIntrinsics& in) {
  out << YAML::BeginMap;
  out << YAML::Key << "type" << YAML::Value << "taylor";
  out << YAML::Key << "image_size" << YAML::Value << YAML::Flow << YAML::BeginSeq << in.width
      << in.height << YAML::EndSeq;
  out << YAML::Key << "centre_row_col" << YAML::Value << YAML::Flow << YAML::BeginSeq << in.xc
      << in.yc << YAML::EndSeq;
  out << YAML::Key << "affine_cde" << YAML::Value << YAML::Flow << YAML::BeginSeq << in.c << in.d
      << in.e << YAML::EndSeq;
  out << YAML::Key << "pol" << YAML::Value << YAML::Flow << in.pol;
  if (!in.invpol.empty()) out << YAML::Key << "invpol" << YAML::Value << YAML::Flow << in.invpol;
  out << YAML::EndMap;
}

// The nearest rotation to a printed (rounded) matrix; rejects matrices far from any rotation.
Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& m, const std::string& at) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0) throw ConfigError(at + ": R is a reflection, not a rotation");
  if ((r - m).cwiseAbs().maxCoeff() > 0.01) {
    throw ConfigError(at +
                      ": R is not a rotation (differs from the nearest one by more than 0.01)");
  }
  return r;
}

struct Edge {
  std::string from, to;
  Eigen::Isometry3d T_to_from;
};

}  // namespace

Rig parse_rig(const std::string& yaml_text, const std::string& src) {
  const YAML::Node root = parse_yaml(yaml_text, src);
  if (!root || root.IsNull()) throw ConfigError(src + ": empty rig file");
  check_keys(src, root, "rig", {"name", "reference", "notes", "cameras", "extrinsics", "stereo"});
  Rig rig;
  rig.name = as_string(src, require(src, root, "rig", "name"), "name");
  rig.reference = as_string(src, require(src, root, "rig", "reference"), "reference");
  if (root["notes"]) {
    for (const auto& note : as_list(src, root["notes"], "notes"))
      rig.notes.push_back(as_string(src, note, "notes"));
  }
  const YAML::Node cams = require(src, root, "rig", "cameras");
  if (!cams.IsMap() || cams.size() == 0)
    throw ConfigError(where(src, cams) + ": cameras: expected a map of cameras");
  for (const auto& item : cams) {
    const std::string name = as_key(src, item.first, "cameras");
    const std::string ctx = "cameras." + name;
    const YAML::Node node = item.second;
    check_keys(src, node, ctx, {"band", "pixel_pitch_um", "bit_depth", "model"});
    RigCamera cam;
    cam.name = name;
    cam.band = as_string(src, require(src, node, ctx, "band"), ctx + ".band");
    if (cam.band != "visible" && cam.band != "infrared") {
      throw ConfigError(where(src, node["band"]) + ": " + ctx +
                        ".band: expected visible or infrared");
    }
    cam.pixel_pitch_um =
        as_double(src, require(src, node, ctx, "pixel_pitch_um"), ctx + ".pixel_pitch_um");
    if (cam.pixel_pitch_um <= 0)
      throw ConfigError(where(src, node["pixel_pitch_um"]) + ": " + ctx +
                        ".pixel_pitch_um: must be positive");
    cam.bit_depth = node["bit_depth"] ? as_int(src, node["bit_depth"], ctx + ".bit_depth") : 8;
    if (cam.bit_depth < 1 || cam.bit_depth > 16)
      throw ConfigError(where(src, node["bit_depth"]) + ": " + ctx + ".bit_depth: must be 1..16");
    cam.model = checked_camera(src, require(src, node, ctx, "model"), ctx + ".model");
    rig.cameras.push_back(std::move(cam));
  }
  if (!rig.has_camera(rig.reference)) {
    throw ConfigError(where(src, root["reference"]) + ": reference: no camera named '" +
                      rig.reference + "'");
  }

  std::vector<Edge> edges;
  if (root["extrinsics"]) {
    const YAML::Node list = root["extrinsics"];
    if (!list.IsSequence()) throw ConfigError(where(src, list) + ": extrinsics: expected a list");
    for (const auto& e : list) {
      check_keys(src, e, "extrinsics", {"from", "to", "R", "t_mm", "note"});
      Edge edge;
      edge.from = as_string(src, require(src, e, "extrinsics", "from"), "extrinsics.from");
      edge.to = as_string(src, require(src, e, "extrinsics", "to"), "extrinsics.to");
      for (const auto& n : {edge.from, edge.to}) {
        if (!rig.has_camera(n))
          throw ConfigError(where(src, e) + ": extrinsics: no camera named '" + n + "'");
      }
      const YAML::Node rn = require(src, e, "extrinsics", "R");
      if (!rn.IsSequence() || rn.size() != 3)
        throw ConfigError(where(src, rn) + ": extrinsics.R: expected 3 rows");
      Eigen::Matrix3d r;
      for (int i = 0; i < 3; ++i) {
        const auto row = as_doubles(src, rn[i], "extrinsics.R row", 3);
        for (int j = 0; j < 3; ++j) r(i, j) = row[j];
      }
      const auto t = as_doubles(src, require(src, e, "extrinsics", "t_mm"), "extrinsics.t_mm", 3);
      edge.T_to_from.setIdentity();
      edge.T_to_from.linear() = nearest_rotation(r, where(src, rn));
      edge.T_to_from.translation() = Eigen::Vector3d(t[0], t[1], t[2]) / 1000.0;
      edges.push_back(edge);
    }
  }
  // Compose the poses outward from the reference camera.
  std::map<std::string, Eigen::Isometry3d> pose{{rig.reference, Eigen::Isometry3d::Identity()}};
  std::queue<std::string> todo;
  todo.push(rig.reference);
  while (!todo.empty()) {
    const std::string at = todo.front();
    todo.pop();
    for (const Edge& edge : edges) {
      if (edge.from == at && !pose.count(edge.to)) {
        pose[edge.to] = pose[at] * edge.T_to_from.inverse();
        todo.push(edge.to);
      } else if (edge.to == at && !pose.count(edge.from)) {
        pose[edge.from] = pose[at] * edge.T_to_from;
        todo.push(edge.from);
      }
    }
  }
  for (auto& cam : rig.cameras) {
    if (!pose.count(cam.name)) {
      throw ConfigError(src + ": extrinsics: camera '" + cam.name +
                        "' is not connected to the reference '" + rig.reference + "'");
    }
    cam.T_ref_cam = pose[cam.name];
  }
  if (root["stereo"]) {
    const YAML::Node st = root["stereo"];
    check_keys(src, st, "stereo", {"visible", "infrared"});
    for (const auto& [key, target] :
         {std::pair{"visible", &rig.visible}, std::pair{"infrared", &rig.infrared}}) {
      if (!st[key]) continue;
      const YAML::Node pair = st[key];
      if (!pair.IsSequence() || pair.size() != 2)
        throw ConfigError(where(src, pair) + ": stereo." + key + ": expected [left, right]");
      target->left = as_string(src, pair[0], std::string("stereo.") + key);
      target->right = as_string(src, pair[1], std::string("stereo.") + key);
      for (const auto& n : {target->left, target->right}) {
        if (!rig.has_camera(n))
          throw ConfigError(where(src, pair) + ": stereo." + key + ": no camera named '" + n + "'");
      }
    }
  }
  return rig;
}

Rig load_rig(const std::filesystem::path& path) {
  return parse_rig(read_text_file(path.string(), "rig file"), path.string());
}

std::string rig_to_yaml(const Rig& rig) {
  YAML::Emitter out;
  out.SetDoublePrecision(10);
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << rig.name;
  out << YAML::Key << "reference" << YAML::Value << rig.reference;
  if (!rig.notes.empty()) out << YAML::Key << "notes" << YAML::Value << rig.notes;
  out << YAML::Key << "cameras" << YAML::Value << YAML::BeginMap;
  for (const auto& cam : rig.cameras) {
    const auto* taylor = dynamic_cast<const camera::TaylorCamera*>(cam.model.get());
    if (taylor == nullptr)
      throw std::runtime_error("rig_to_yaml: camera '" + cam.name + "' is not a Taylor model");
    out << YAML::Key << cam.name << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "band" << YAML::Value << cam.band;
    out << YAML::Key << "pixel_pitch_um" << YAML::Value << cam.pixel_pitch_um;
    out << YAML::Key << "bit_depth" << YAML::Value << cam.bit_depth;
    out << YAML::Key << "model" << YAML::Value;
    emit_taylor(out, taylor->intrinsics());
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  out << YAML::Key << "extrinsics" << YAML::Value << YAML::BeginSeq;
  const auto& ref = rig.camera(rig.reference);
  for (const auto& cam : rig.cameras) {
    if (cam.name == ref.name) continue;
    // X_cam = T_cam_ref * X_ref
    const Eigen::Isometry3d T = cam.T_ref_cam.inverse();
    out << YAML::BeginMap << YAML::Key << "from" << YAML::Value << ref.name << YAML::Key << "to"
        << YAML::Value << cam.name << YAML::Key << "R" << YAML::Value << YAML::BeginSeq;
    for (int i = 0; i < 3; ++i) {
      out << YAML::Flow << YAML::BeginSeq << T.linear()(i, 0) << T.linear()(i, 1)
          << T.linear()(i, 2) << YAML::EndSeq;
    }
    const Eigen::Vector3d t = T.translation() * 1000.0;
    out << YAML::EndSeq << YAML::Key << "t_mm" << YAML::Value << YAML::Flow << YAML::BeginSeq
        << t.x() << t.y() << t.z() << YAML::EndSeq << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "stereo" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "visible" << YAML::Value << YAML::Flow << YAML::BeginSeq << rig.visible.left
      << rig.visible.right << YAML::EndSeq;
  out << YAML::Key << "infrared" << YAML::Value << YAML::Flow << YAML::BeginSeq << rig.infrared.left
      << rig.infrared.right << YAML::EndSeq;
  out << YAML::EndMap;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

void save_rig(const Rig& rig, const std::filesystem::path& path) {
  const std::string text = rig_to_yaml(rig);
  std::ofstream out(path);
  if (!out || !(out << text)) throw std::runtime_error(path.string() + ": cannot write");
}

camera::TaylorIntrinsics parse_taylor_yaml(const std::string& yaml_text, const std::string& src) {
  const YAML::Node root = parse_yaml(yaml_text, src);
  if (!root || !root.IsMap()) throw ConfigError(src + ": expected a camera model map");
  // Accept either the model block itself or a camera entry holding `model:`.
  const YAML::Node model = root["model"] ? root["model"] : root;
  // The intrinsics as written (an absent invpol stays absent); the camera only checks them.
  checked_camera(src, model, "model");
  return taylor_from_node(src, model, "model");
}

camera::TaylorIntrinsics load_taylor_yaml(const std::filesystem::path& path) {
  return parse_taylor_yaml(read_text_file(path.string(), "camera file"), path.string());
}

std::string taylor_to_yaml(const camera::TaylorIntrinsics& intrinsics) {
  YAML::Emitter out;
  out.SetDoublePrecision(12);
  out << YAML::BeginMap << YAML::Key << "model" << YAML::Value;
  emit_taylor(out, intrinsics);
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::filesystem::path shipped_file(const std::string& relative) {
  std::vector<std::filesystem::path> roots;
  if (const char* env = std::getenv("THERMOVIS_DEPLOY_DIR"); env != nullptr && *env != '\0') {
    roots.emplace_back(env);
  }
  roots.emplace_back(std::filesystem::path(THERMOVIS_SOURCE_DIR) / "deploy");
  roots.emplace_back("/usr/local/share/thermovis");
  for (const auto& root : roots) {
    if (std::filesystem::exists(root / relative)) return root / relative;
  }
  throw ConfigError("shipped file '" + relative + "' not found under $THERMOVIS_DEPLOY_DIR, " +
                    (std::filesystem::path(THERMOVIS_SOURCE_DIR) / "deploy").string() +
                    " or /usr/local/share/thermovis");
}

std::filesystem::path default_rig_path() {
  if (const char* env = std::getenv("THERMOVIS_RIG"); env != nullptr && *env != '\0') return env;
  return shipped_file("rigs/paper.yaml");
}

camera::Rig load_rig_or_default(const std::filesystem::path& path) {
  return load_rig(path.empty() ? default_rig_path() : path);
}

}  // namespace thermovis::runtime
