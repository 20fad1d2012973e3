#include "thermovis/node/geometry_topic.hpp"

#include <algorithm>
#include <stdexcept>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::node {
namespace {

Pose pose_of(const Eigen::Isometry3d& T) {
  Pose p;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      p.rotation()[static_cast<std::size_t>(3 * r + c)] = T.linear()(r, c);
    p.translation_m()[static_cast<std::size_t>(r)] = T.translation()(r);
  }
  return p;
}

Eigen::Isometry3d isometry_of(const Pose& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      T.linear()(r, c) = p.rotation()[static_cast<std::size_t>(3 * r + c)];
    T.translation()(r) = p.translation_m()[static_cast<std::size_t>(r)];
  }
  return T;
}

PairGeometry pair_message(const pipeline::PairGeometry& pair) {
  PairGeometry m;
  m.left_camera(pair.left_camera);
  m.right_camera(pair.right_camera);
  m.ref_from_left_rect(pose_of(pair.T_ref_left_rect));
  m.ref_from_right_rect(pose_of(pair.T_ref_right_rect));
  m.baseline_m(pair.baseline_m);
  return m;
}

pipeline::PairGeometry pair_of(const PairGeometry& m) {
  return {m.left_camera().to_string(), m.right_camera().to_string(),
          isometry_of(m.ref_from_left_rect()), isometry_of(m.ref_from_right_rect()),
          m.baseline_m()};
}

}  // namespace

GridGeometry to_message(const pipeline::PipelineGeometry& g) {
  GridGeometry m;
  m.geometry_id(g.id());
  RectifiedGrid grid;
  grid.width(static_cast<std::uint32_t>(g.grid.width));
  grid.height(static_cast<std::uint32_t>(g.grid.height));
  grid.f_px(g.grid.f);
  grid.cx_px(g.grid.cx);
  grid.cy_px(g.grid.cy);
  grid.projection(g.grid.projection == camera::RectifiedProjection::cylindrical
                      ? PROJECTION_CYLINDRICAL
                      : PROJECTION_EQUIRECTANGULAR);
  m.grid(grid);
  m.visible(pair_message(g.visible));
  m.infrared(pair_message(g.infrared));
  m.ref_from_reporting(pose_of(g.T_ref_reporting));
  m.registration_distance_m(g.registration_distance_m);
  m.infrared_reduction(static_cast<std::uint32_t>(g.infrared_reduction));
  return m;
}

pipeline::PipelineGeometry from_message(const GridGeometry& m) {
  pipeline::PipelineGeometry g;
  const RectifiedGrid& grid = m.grid();
  if (grid.projection() != PROJECTION_EQUIRECTANGULAR &&
      grid.projection() != PROJECTION_CYLINDRICAL) {
    throw FrameError("geometry: unknown projection " + std::to_string(grid.projection()));
  }
  // Bounded before the cast; pipeline::validate checks it against the frame type's capacity.
  g.grid.width = static_cast<int>(std::min<std::uint32_t>(grid.width(), 1u << 20));
  g.grid.height = static_cast<int>(std::min<std::uint32_t>(grid.height(), 1u << 20));
  g.grid.f = grid.f_px();
  g.grid.cx = grid.cx_px();
  g.grid.cy = grid.cy_px();
  g.grid.projection = grid.projection() == PROJECTION_CYLINDRICAL
                          ? camera::RectifiedProjection::cylindrical
                          : camera::RectifiedProjection::equirectangular;
  g.visible = pair_of(m.visible());
  g.infrared = pair_of(m.infrared());
  g.T_ref_reporting = isometry_of(m.ref_from_reporting());
  g.registration_distance_m = m.registration_distance_m();
  // Bounded before the cast; validate says what is wrong with it.
  g.infrared_reduction = static_cast<int>(std::min<std::uint32_t>(m.infrared_reduction(), 1000));
  try {
    pipeline::validate(g, {GRID_WIDTH, GRID_HEIGHT});
  } catch (const std::invalid_argument& e) {
    throw FrameError(e.what());
  }
  if (g.id() != m.geometry_id()) {
    throw FrameError("geometry: geometry_id " + std::to_string(m.geometry_id()) +
                     " is not the digest of its fields (" + std::to_string(g.id()) + ")");
  }
  return g;
}

GeometryPublisher::GeometryPublisher(transport::Participant& participant,
                                     const pipeline::PipelineGeometry& geometry)
    : writer_(participant, transport::topics::kGeometry, transport::state_topic_qos()) {
  writer_.write(to_message(geometry));
}

GeometrySubscriber::GeometrySubscriber(transport::Participant& participant)
    : reader_(participant, transport::topics::kGeometry, transport::state_topic_qos()) {}

bool GeometrySubscriber::poll(std::chrono::milliseconds wait) {
  if (wait.count() > 0 && !reader_.wait_for_data(wait)) return false;
  auto samples = reader_.take();
  if (samples.empty()) return false;
  const GridGeometry& newest = samples[samples.size() - 1];
  if (geometry_ && newest.geometry_id() == id_) return false;
  pipeline::PipelineGeometry g = from_message(newest);
  geometry_ = std::move(g);
  id_ = newest.geometry_id();
  return true;
}

}  // namespace thermovis::node
