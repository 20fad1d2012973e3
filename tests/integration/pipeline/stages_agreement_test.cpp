// One pipeline core: the separate services range each capture exactly as the stage classes do
// in one process (what `thermovis range`, `bench ranging` and `bench stages` run). The shipped
// manifest runs on the simulated paper scene, rendering every capture live, so capture seq k is
// frame k of the simulated rig; the test renders the same frames itself, runs
// pipeline::CapturePipeline on them with the services' default options and compares every
// target of every result the services published: the same boxes, the same distances and sigmas.
//
// The infrared gain control is smoothed over frames, so its state depends on which captures
// rectify-fuse saw; the in-process run feeds it every frame from 0 and the comparison starts
// once the smoothing has forgotten the start (0.8^n of the first mapping: under 1e-9 after
// 100 captures).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <iostream>
#include <map>
#include <sstream>
#include <vector>

#include "pipeline_harness.hpp"
#include "thermovis/match/stereo_match.hpp"
#include "thermovis/perception.h"
#include "thermovis/pipeline/capture_pipeline.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"

namespace {

using namespace std::chrono_literals;
namespace tv = thermovis;
namespace pl = thermovis::pipeline;

// The published ranges are float32: what both sides give must agree to its rounding.
constexpr double kRelative = 1e-6;

// A pair's matches as the range service receives them: the match topic carries coordinates and
// the region's figures as float32 (thermovis/perception.idl), the stages in one process keep
// double. Rounded here as thermovis-range reads them, so that any other difference shows.
pl::TargetEntry as_published(const pl::BandMatches& m, const std::string& label,
                             const cv::Rect& box) {
  auto f = [](double v) { return static_cast<double>(static_cast<float>(v)); };
  pl::TargetEntry entry{m.band, label, box, {}, {}};
  for (const auto& p : m.result.matches) {
    tv::match::Correspondence c;
    c.left = {f(p.left.x()), f(p.left.y())};
    c.right = {f(p.right.x()), f(p.right.y())};
    c.disparity_px = c.left.x() - c.right.x();
    c.score = 1.0;
    entry.points.push_back(c);
  }
  const auto& r = m.result.region;
  if (r.ok()) {
    entry.region.status = tv::match::RegionStatus::ok;
    entry.region.anchor = {f(r.anchor.x()), f(r.anchor.y())};
    entry.region.disparity_px = f(r.disparity_px);
    entry.region.sigma_px = f(r.sigma_px);
    entry.region.contour_fraction = f(r.contour_fraction);
    entry.region.pixels = r.pixels;
  }
  return entry;
}

// A target as both sides give it, in the published precision.
struct Ranged {
  float x = 0, y = 0, width = 0, height = 0;
  float distance_m = 0, sigma_m = 0;
  std::string describe() const {
    std::ostringstream s;
    s << "box (" << x << ", " << y << ", " << width << " x " << height << ") at " << distance_m
      << " m, sigma " << sigma_m << " m";
    return s.str();
  }
};

bool by_box(const Ranged& a, const Ranged& b) {
  return std::tie(a.x, a.y, a.width, a.height) < std::tie(b.x, b.y, b.width, b.height);
}

std::string describe(const std::vector<Ranged>& targets) {
  std::string out;
  for (const Ranged& t : targets) out += "\n    " + t.describe();
  return out.empty() ? "\n    (none)" : out;
}

// The services' ranges of each capture, from seq `from` on.
std::map<std::uint64_t, std::vector<Ranged>> published_ranges(int domain, std::uint64_t from,
                                                              std::size_t count,
                                                              tv::test::ChildProcess& supervisor) {
  const auto participant = tv::test::loopback_participant(domain, "stages-agreement-test");
  tv::transport::Reader<tv::RangeArray> reader(*participant, tv::transport::topics::kRanges,
                                               tv::transport::event_topic_qos(64));
  std::map<std::uint64_t, std::vector<Ranged>> out;
  const auto until = std::chrono::steady_clock::now() + 240s;
  while (std::chrono::steady_clock::now() < until && out.size() < count) {
    reader.wait_for_data(100ms);
    auto samples = reader.take();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const tv::RangeArray& a = samples[i];
      if (a.frame_seq() < from) continue;
      std::vector<Ranged>& targets = out[a.frame_seq()];
      for (const tv::TargetRange& r : a.targets()) {
        targets.push_back({r.box().x(), r.box().y(), r.box().width(), r.box().height(),
                           r.distance_m(), r.sigma_m()});
      }
      std::sort(targets.begin(), targets.end(), by_box);
    }
    if (supervisor.poll().has_value()) break;
  }
  return out;
}

TEST(StagesAgreement, TheServicesRangeEveryCaptureAsTheStagesDoInOneProcess) {
  const auto dir = tv::test::temp_dir("stages-agreement");
  const int domain = tv::test::private_domain();
  const auto scene_path = tv::test::source_root() / "deploy/scenes/paper.yaml";
  tv::test::ChildProcess supervisor(
      tv::test::supervisor_command(dir, domain, {"--scene", scene_path.string()}),
      dir / "supervisor.log");

  constexpr std::uint64_t kFirstCompared = 100;  // the gain control's start forgotten
  constexpr std::size_t kCompared = 60;
  const auto published = published_ranges(domain, kFirstCompared, kCompared, supervisor);
  supervisor.signal(SIGTERM);
  ASSERT_TRUE(supervisor.wait(60s).has_value()) << supervisor.log();
  ASSERT_GE(published.size(), kCompared / 2) << "supervisor log:\n"
                                             << supervisor.log() << tv::test::service_logs(dir);

  // The same captures through the stages in one process: the bridge's rig, scene and seed
  // (thermovis-bridge defaults), the services' default options.
  const auto rig = tv::runtime::load_rig(tv::runtime::default_rig_path());
  const tv::sim::SimulatedRig simulated(rig, tv::runtime::load_scene(scene_path), 1);
  pl::CapturePipelineOptions options;
  options.fuse = true;  // detect finds people on rectify-fuse's fused image
  pl::CapturePipeline pipeline(rig, options);
  tv::sim::FrameSet frames = simulated.allocate();
  const std::uint64_t last = published.rbegin()->first;
  std::size_t targets = 0, compared = 0;
  double worst_distance = 0, worst_sigma = 0;  // relative differences
  for (std::uint64_t seq = 0; seq <= last; ++seq) {
    simulated.render(static_cast<std::int64_t>(seq), frames);
    const pl::GridCapture capture = pipeline.rectify(
        {frames[tv::sim::Slot::visible_left], frames[tv::sim::Slot::visible_right],
         frames[tv::sim::Slot::infrared_left], frames[tv::sim::Slot::infrared_right]});
    const auto it = published.find(seq);
    if (it == published.end()) continue;
    std::vector<Ranged> ours;
    const pl::MatchImages images{
        capture.grey_left, capture.grey_right, capture.infrared_left, capture.infrared_right, {}};
    for (const auto& d : pipeline.detect(capture)) {
      std::vector<pl::TargetEntry> entries;
      for (const auto& m : pipeline.match_stage(pl::BandChoice::both).match(images, d.box, d.cls))
        entries.push_back(as_published(m, d.cls, d.box));
      if (entries.empty()) continue;
      const pl::RangedTarget ranged = pipeline.range_stage().range(entries);
      if (!ranged.ok()) continue;
      ours.push_back({static_cast<float>(d.box.x), static_cast<float>(d.box.y),
                      static_cast<float>(d.box.width), static_cast<float>(d.box.height),
                      static_cast<float>(ranged.distance_m),
                      static_cast<float>(ranged.range.sigma_m)});
    }
    std::sort(ours.begin(), ours.end(), by_box);
    ++compared;
    const std::vector<Ranged>& theirs = it->second;
    bool same = ours.size() == theirs.size();
    for (std::size_t i = 0; same && i < ours.size(); ++i) {
      const double distance =
          std::abs(ours[i].distance_m - theirs[i].distance_m) / ours[i].distance_m;
      const double sigma = std::abs(ours[i].sigma_m - theirs[i].sigma_m) / ours[i].sigma_m;
      worst_distance = std::max(worst_distance, distance);
      worst_sigma = std::max(worst_sigma, sigma);
      same = !by_box(ours[i], theirs[i]) && !by_box(theirs[i], ours[i]) && distance <= kRelative &&
             sigma <= kRelative;
    }
    EXPECT_TRUE(same) << "capture " << seq << ": the services ranged" << describe(theirs)
                      << "\n  the stages in one process" << describe(ours);
    targets += theirs.size();
  }
  std::cout << compared << " captures, " << targets << " targets compared; largest relative "
            << "difference: distance " << worst_distance << ", sigma " << worst_sigma << "\n";
  EXPECT_GE(compared, kCompared / 2);
  EXPECT_GE(targets, 4 * compared) << "the paper scene's people were rarely ranged";
  std::filesystem::remove_all(dir);
}

}  // namespace
