// An external detector from another DDS vendor: the pipeline runs without thermovis-detect
// (bridge on the simulated paper scene, rectify-fuse, match, range, started directly on a
// private domain) and thermovis-tap --publish (Cyclone DDS) feeds thermovis/detections. The test
// plays the detector's eyes: it reads each fused frame's seq and capture time (Fast DDS), boxes
// the simulated people of that capture on the rectified grid from the simulator's truth, and
// hands the JSON line to the Cyclone publisher through a FIFO. The ranges that come out must be
// for those frames and targets, at the true distances.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <thread>

#include "pipeline_harness.hpp"
#include "thermovis/pipeline/geometry.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/test/child_process.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/topics.hpp"

namespace {

using namespace std::chrono_literals;
using thermovis::test::ChildProcess;
namespace tv = thermovis;
namespace topics = tv::transport::topics;

TEST(ExternalDetector, CycloneDetectionsAreRangedByThePipeline) {
  const auto dir = tv::test::temp_dir("external_detector");
  const int domain = tv::test::private_domain();
  const auto scene_path = tv::test::source_root() / "deploy/scenes/paper.yaml";
  const auto fifo = dir / "detections.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);

  auto service = [&](const std::string& name, std::vector<std::string> extra = {}) {
    return std::make_unique<ChildProcess>(
        tv::test::service_command("thermovis-" + name, domain, extra), dir / (name + ".log"));
  };
  std::vector<std::unique_ptr<ChildProcess>> services;
  // 10 captures a second: the detector's round trip (test -> FIFO -> Cyclone -> match) stays
  // well inside the frames match keeps. (DEADLINE stays at its 20 ms everywhere, misses are only
  // counted: a writer offering a longer period than its readers request would not match them.)
  services.push_back(
      service("bridge", {"--source", "sim", "--scene", scene_path.string(), "--rate", "10"}));
  services.push_back(service("rectify-fuse"));
  services.push_back(service("match"));
  services.push_back(service("range"));
  auto logs = [&] {
    std::string all;
    for (const auto& s : services) all += s->log() + "\n";
    return all;
  };
  const std::string cyclone_config =
      "file://" + (tv::test::source_root() / "deploy/dds/cyclonedds-loopback.xml").string();
  ChildProcess publisher(
      {(tv::test::bin_dir() / "thermovis-tap").string(), "--publish", topics::kDetections, "--from",
       fifo.string(), "--domain", std::to_string(domain), "--wait-readers", "1"},
      dir / "publisher.log", {{"CYCLONEDDS_URI", cyclone_config}});
  // The detector's end of the FIFO, opened once the publisher reads it (non-blocking attempts,
  // so a publisher that failed to start fails the test instead of hanging it).
  std::signal(SIGPIPE, SIG_IGN);
  int detector = -1;
  for (const auto open_until = std::chrono::steady_clock::now() + 30s;
       detector < 0 && std::chrono::steady_clock::now() < open_until;) {
    detector = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (detector < 0) std::this_thread::sleep_for(20ms);
  }
  ASSERT_GE(detector, 0) << publisher.log();
  ::fcntl(detector, F_SETFL, 0);  // blocking writes from here on
  auto send = [&](const std::string& text) {
    return ::write(detector, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  };

  const auto participant = tv::test::loopback_participant(domain, "external-detector-test");
  tv::transport::Reader<tv::GridStereoFrame> fused(*participant, topics::kFused,
                                                   tv::transport::frame_topic_qos(0ns, 2, 2));
  tv::transport::Reader<tv::RangeArray> ranges(*participant, topics::kRanges,
                                               tv::transport::event_topic_qos(64));

  const auto rig = tv::runtime::load_rig(tv::runtime::default_rig_path());
  const auto geometry = tv::pipeline::make_geometry(rig, {});
  const cv::Rect grid(cv::Point(0, 0), geometry.grid_size());
  const tv::sim::SimulatedRig sim(rig, tv::runtime::load_scene(scene_path), 1,
                                  tv::sim::RenderOptions{false, false});

  struct Sent {
    std::int64_t capture_ns = 0;
    std::map<std::uint32_t, tv::sim::TargetTruth> targets;  // by target_id
  };
  std::map<std::uint64_t, Sent> sent;
  std::map<std::string, std::vector<double>> measured;  // truth id -> distances
  std::map<std::string, double> truth_m;
  std::uint64_t lines = 0, arrays = 0, ranged = 0;
  const auto until = std::chrono::steady_clock::now() + 60s;
  while (std::chrono::steady_clock::now() < until && arrays < 40) {
    fused.wait_for_data(50ms);
    auto frames = fused.take();
    for (std::size_t i = 0; i < frames.size(); ++i) {
      const std::uint64_t seq = frames[i].seq();
      Sent& s = sent[seq];
      s.capture_ns = frames[i].capture_time_ns();
      nlohmann::json detections = nlohmann::json::array();
      std::uint32_t id = 0;
      for (const auto& t : sim.truth(static_cast<std::int64_t>(seq))) {
        const auto& raw = t.boxes[static_cast<std::size_t>(tv::sim::Slot::visible_left)];
        if (t.cls != tv::sim::TargetClass::person || !raw) continue;
        const cv::Rect box =
            tv::pipeline::raw_box_on_grid(geometry, rig, tv::pipeline::Band::visible, raw->x_min,
                                          raw->y_min, raw->x_max, raw->y_max) &
            grid;
        if (box.width < 4 || box.height < 8) continue;
        s.targets[++id] = t;
        detections.push_back(
            {{"target_id", id},
             {"label", "person"},
             {"score", 0.9},
             {"box", {{"x", box.x}, {"y", box.y}, {"width", box.width}, {"height", box.height}}}});
      }
      const nlohmann::json line = {
          {"frame_seq", seq}, {"capture_time_ns", s.capture_ns}, {"detections", detections}};
      ASSERT_TRUE(send(line.dump() + "\n")) << publisher.log();
      ++lines;
    }
    auto results = ranges.take();
    for (std::size_t i = 0; i < results.size(); ++i) {
      const tv::RangeArray& a = results[i];
      const auto it = sent.find(a.frame_seq());
      ASSERT_NE(it, sent.end()) << "ranges of frame " << a.frame_seq() << " nobody detected";
      EXPECT_EQ(a.capture_time_ns(), it->second.capture_ns);
      ++arrays;
      for (const tv::TargetRange& r : a.targets()) {
        const auto t = it->second.targets.find(r.target_id());
        ASSERT_NE(t, it->second.targets.end()) << "target " << r.target_id();
        EXPECT_EQ(r.label().to_string(), "person");
        measured[t->second.id].push_back(r.distance_m());
        truth_m[t->second.id] = t->second.distance_m;
        ++ranged;
      }
    }
  }
  // Services stop first (downstream first), so their logs end with their statistics.
  for (auto it = services.rbegin(); it != services.rend(); ++it) {
    (*it)->signal(SIGTERM);
    EXPECT_EQ((*it)->wait(30s), 0) << (*it)->log();
  }
  ASSERT_GE(arrays, 20u) << lines << " detection lines sent\n" << logs() << publisher.log();

  // Per person: the mean distance within 6 % of the truth (as for the pipeline's own detector,
  // pipeline_test), over every person ranged in at least a quarter of the frames.
  int people = 0;
  for (const auto& [id, list] : measured) {
    if (list.size() < arrays / 4) continue;
    ++people;
    double mean = 0;
    for (double d : list) mean += d;
    mean /= static_cast<double>(list.size());
    EXPECT_NEAR(mean, truth_m[id], 0.06 * truth_m[id]) << id << " over " << list.size();
    std::cout << id << ": truth " << truth_m[id] << " m, mean " << mean << " m over " << list.size()
              << " frames\n";
  }
  EXPECT_GE(people, 5) << ranged << " ranges in " << arrays << " arrays";

  // End of the detector's stream: the publisher says how many it published, and exits 0.
  ::close(detector);
  ASSERT_EQ(publisher.wait(30s), 0) << publisher.log();
  EXPECT_NE(publisher.log().find("published " + std::to_string(lines) + " samples"),
            std::string::npos)
      << publisher.log();
  std::filesystem::remove_all(dir);
}

}  // namespace
