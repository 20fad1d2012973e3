#pragma once
// The pipeline geometry on thermovis/geometry (GridGeometry, RELIABLE + TRANSIENT_LOCAL,
// KEEP_LAST 1): rectify-fuse publishes it, every grid service takes it from there instead of
// rebuilding it from its own flags, so a frame on another grid cannot be misread.
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "thermovis/geometry.h"
#include "thermovis/node/health.hpp"
#include "thermovis/pipeline/geometry.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::node {

// Message <-> geometry. from_message validates (pipeline::validate: the grid must fit a
// GridStereoFrame, GRID_WIDTH x GRID_HEIGHT) and checks geometry_id against the digest of the
// fields: FrameError naming the field otherwise.
GridGeometry to_message(const pipeline::PipelineGeometry& geometry);
pipeline::PipelineGeometry from_message(const GridGeometry& message);

class GeometryPublisher {
 public:
  GeometryPublisher(transport::Participant& participant,
                    const pipeline::PipelineGeometry& geometry);
  transport::TopicCountersSnapshot counters() const { return writer_.counters(); }

 private:
  transport::Writer<GridGeometry> writer_;
};

// The geometry a downstream service works on: the latest valid one received.
class GeometrySubscriber {
 public:
  explicit GeometrySubscriber(transport::Participant& participant);
  // Takes what arrived (waiting at most `wait` for it). True when a new, valid geometry was
  // taken; a bad one throws FrameError (the one held stays).
  bool poll(std::chrono::milliseconds wait = std::chrono::milliseconds(0));
  const std::optional<pipeline::PipelineGeometry>& geometry() const { return geometry_; }
  std::uint32_t id() const { return id_; }
  transport::TopicCountersSnapshot counters() const { return reader_.counters(); }

 private:
  transport::Reader<GridGeometry> reader_;
  std::optional<pipeline::PipelineGeometry> geometry_;
  std::uint32_t id_ = 0;
};

// A downstream service's stage, built on the geometry of thermovis/geometry once it arrives and
// rebuilt when another one comes (rectify-fuse restarted with other grid options). Stage is
// constructible from (const pipeline::PipelineGeometry&, const Options&).
template <class Stage, class Options>
class StageOnGeometry {
 public:
  StageOnGeometry(transport::Participant& participant, Options options)
      : geometry_(participant), options_(std::move(options)) {}
  // Takes a new geometry if one came (waiting at most `wait`) and rebuilds the stage on it. A bad
  // geometry is reported to `health` as bad input and the one held stays. True when a stage is
  // there.
  bool refresh(HealthReporter& health, std::chrono::milliseconds wait = {}) {
    try {
      if (geometry_.poll(wait)) stage_ = std::make_unique<Stage>(*geometry_.geometry(), options_);
    } catch (const std::exception& e) {
      health.bad_input(std::string(transport::topics::kGeometry) + ": " + e.what());
    }
    return stage_ != nullptr;
  }
  // The stage, the geometry it was built on and that geometry's id; only after refresh() gave
  // true.
  Stage& stage() const { return *stage_; }
  const pipeline::PipelineGeometry& geometry() const { return *geometry_.geometry(); }
  std::uint32_t id() const { return geometry_.id(); }
  transport::TopicCountersSnapshot counters() const { return geometry_.counters(); }

 private:
  GeometrySubscriber geometry_;
  Options options_;
  std::unique_ptr<Stage> stage_;
};

// A downstream service's start: waits (ticking its health) until the geometry has come and
// the stage is built, then says what it waits for next ("waiting for <what>").
template <class Stage, class Options>
void wait_for_geometry(StageOnGeometry<Stage, Options>& stage, HealthReporter& health,
                       const std::string& what, const std::function<bool()>& stop) {
  while (!stop() && !stage.refresh(health, std::chrono::milliseconds(100))) health.tick();
  if (stop()) return;
  const cv::Size grid = stage.geometry().grid_size();
  health.set_state(HEALTH_STARTING, "grid " + std::to_string(grid.width) + "x" +
                                        std::to_string(grid.height) + " (geometry " +
                                        std::to_string(stage.id()) + "), waiting for " + what);
}

}  // namespace thermovis::node
