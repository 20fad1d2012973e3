// The bridge's frame sources without DDS: the files source plays a `thermovis scene render`
// folder and names the file of every bad input; the fpga-dma source reads what the FPGA side of
// the capture ring writes (as thermovis-fpga-emu does), follows a re-created ring and rejects a
// ring that does not fit the rig; the sim source's prerendered captures are the live ones.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>
#include <vector>

#include "frame_source.hpp"
#include "thermovis/camera/taylor.hpp"
#include "thermovis/fpga/ring.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/test/images.hpp"

namespace {

namespace fs = std::filesystem;
using thermovis::bridge::FrameSource;
using thermovis::bridge::make_source;
using thermovis::bridge::SourceOptions;
using thermovis::sim::FrameSet;
using thermovis::sim::Slot;
using namespace std::chrono_literals;

// The paper's rig with every camera's pixel grid scaled down by `s` (visible 1/20: 96x54,
// infrared 1/16: 64x48): the same optics, images small enough for fast tests. For a Taylor model
// whose pixel coordinates scale by s, a_i' = a_i s^(1 - i) and the centre scales likewise.
thermovis::camera::Rig tiny_rig() {
  auto rig =
      thermovis::runtime::load_rig(thermovis::test::source_root() / "deploy/rigs/paper.yaml");
  for (auto& camera : rig.cameras) {
    const auto& taylor = dynamic_cast<const thermovis::camera::TaylorCamera&>(*camera.model);
    auto intrinsics = taylor.intrinsics();
    const double s = camera.band == "visible" ? 1.0 / 20 : 1.0 / 16;
    intrinsics.width = static_cast<int>(intrinsics.width * s);
    intrinsics.height = static_cast<int>(intrinsics.height * s);
    intrinsics.xc = (intrinsics.xc + 0.5) * s - 0.5;
    intrinsics.yc = (intrinsics.yc + 0.5) * s - 0.5;
    for (std::size_t i = 0; i < intrinsics.pol.size(); ++i)
      intrinsics.pol[i] *= std::pow(s, 1.0 - static_cast<double>(i));
    intrinsics.invpol.clear();
    camera.model = std::make_shared<thermovis::camera::TaylorCamera>(intrinsics);
  }
  return rig;
}

const cv::Size kVisible{96, 54};
const cv::Size kInfrared{64, 48};

FrameSet allocate(const FrameSource& source) {
  FrameSet frames;
  frames[Slot::visible_left].create(source.visible_size(), CV_8UC3);
  frames[Slot::visible_right].create(source.visible_size(), CV_8UC3);
  frames[Slot::infrared_left].create(source.infrared_size(), CV_16UC1);
  frames[Slot::infrared_right].create(source.infrared_size(), CV_16UC1);
  return frames;
}

// Seeded test images of one frame, different in every camera and frame.
FrameSet test_frame(int frame) {
  FrameSet frames;
  frames.images =
      thermovis::test::seeded_capture(static_cast<std::uint64_t>(77 + frame), kVisible, kInfrared);
  return frames;
}

using thermovis::test::identical;

void expect_equal(const FrameSet& got, const FrameSet& want) {
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(identical(got.images[static_cast<std::size_t>(i)],
                          want.images[static_cast<std::size_t>(i)]))
        << to_string(static_cast<Slot>(i));
  }
}

std::string error_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

class Sources : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = thermovis::test::temp_dir("bridge-sources"); }
  void TearDown() override { fs::remove_all(dir_); }

  // A folder as `thermovis scene render --out` writes it: <dir>/<000000>/<camera>.png.
  fs::path write_folder(int frame_count) const {
    const fs::path root = dir_ / "render";
    for (int frame = 0; frame < frame_count; ++frame) {
      std::ostringstream name;
      name << std::setw(6) << std::setfill('0') << frame;
      fs::create_directories(root / name.str());
      const FrameSet images = test_frame(frame);
      for (int i = 0; i < 4; ++i) {
        const fs::path file =
            root / name.str() / (std::string(to_string(static_cast<Slot>(i))) + ".png");
        EXPECT_TRUE(cv::imwrite(file.string(), images.images[static_cast<std::size_t>(i)]));
      }
      std::ofstream(root / name.str() / "truth.json") << "{}\n";
    }
    return root;
  }

  std::unique_ptr<FrameSource> files_source(const fs::path& root, bool loop = true,
                                            bool preload = false) const {
    SourceOptions options;
    options.kind = "files";
    options.directory = root.string();
    options.loop = loop;
    options.preload = preload;
    return make_source(options, rig_);
  }

  fs::path dir_;
  thermovis::camera::Rig rig_ = tiny_rig();
};

TEST_F(Sources, FilesSourcePlaysTheFolderInOrderAndLoops) {
  const auto root = write_folder(3);
  for (const bool preload : {false, true}) {
    SCOPED_TRACE(preload ? "preloaded" : "decoded live");
    auto source = files_source(root, true, preload);
    EXPECT_EQ(source->visible_size(), kVisible);
    EXPECT_EQ(source->infrared_size(), kInfrared);
    EXPECT_FALSE(source->self_paced());
    FrameSet frames = allocate(*source);
    for (int index = 0; index < 7; ++index) {
      ASSERT_TRUE(source->fill(index, frames));
      expect_equal(frames, test_frame(index % 3));
    }
  }
}

TEST_F(Sources, FilesSourceWithoutLoopEndsAfterTheLastFrame) {
  auto source = files_source(write_folder(2), false);
  FrameSet frames = allocate(*source);
  ASSERT_TRUE(source->fill(1, frames));
  expect_equal(frames, test_frame(1));
  EXPECT_FALSE(source->fill(2, frames));
}

TEST_F(Sources, FilesSourceNamesTheBadFileAndGoesOn) {
  const auto root = write_folder(5);
  const fs::path missing = root / "000001" / "infrared_right.png";
  fs::remove(missing);
  const fs::path corrupt = root / "000002" / "visible_left.png";
  std::ofstream(corrupt, std::ios::trunc) << "\x89PNG\r\n this is not a PNG any more";
  const fs::path small = root / "000003" / "infrared_left.png";
  cv::imwrite(small.string(), cv::Mat(10, 12, CV_16UC1, cv::Scalar(100)));
  const fs::path eight_bit = root / "000004" / "infrared_right.png";
  cv::imwrite(eight_bit.string(), cv::Mat(kInfrared, CV_8UC1, cv::Scalar(100)));

  for (const bool preload : {false, true}) {
    SCOPED_TRACE(preload ? "preloaded" : "decoded live");
    auto source = files_source(root, true, preload);
    FrameSet frames = allocate(*source);
    std::string message = error_of([&] { source->fill(1, frames); });
    EXPECT_NE(message.find("missing " + missing.string()), std::string::npos) << message;
    message = error_of([&] { source->fill(2, frames); });
    EXPECT_NE(message.find("cannot decode " + corrupt.string()), std::string::npos) << message;
    message = error_of([&] { source->fill(3, frames); });
    EXPECT_NE(message.find(small.string() + " is 12x10, the rig's infrared camera is 64x48"),
              std::string::npos)
        << message;
    message = error_of([&] { source->fill(4, frames); });
    EXPECT_NE(message.find(eight_bit.string() + " is 8-bit 1-channel, expected 16-bit 1-channel"),
              std::string::npos)
        << message;
    // The next capture after the bad ones is fine, and the outgoing buffers kept their shape.
    ASSERT_TRUE(source->fill(5, frames));
    expect_equal(frames, test_frame(0));
    message = error_of([&] { source->fill(7, frames); });  // the bad frames come round again
    EXPECT_NE(message.find("cannot decode " + corrupt.string()), std::string::npos) << message;
  }
}

TEST_F(Sources, FilesSourceRejectsAFolderWithoutFrames) {
  fs::create_directories(dir_ / "empty" / "notes");
  std::string message = error_of([&] { files_source(dir_ / "empty"); });
  EXPECT_NE(message.find("holds no frames"), std::string::npos) << message;
  message = error_of([&] { files_source(dir_ / "absent"); });
  EXPECT_NE(message.find((dir_ / "absent").string() + " is not a folder"), std::string::npos)
      << message;
  message = error_of([&] { files_source(""); });
  EXPECT_NE(message.find("--dir is required"), std::string::npos) << message;
}

TEST_F(Sources, UnknownKindListsTheKnownOnes) {
  SourceOptions options;
  options.kind = "camera";
  const std::string message = error_of([&] { make_source(options, rig_); });
  EXPECT_NE(message.find("sim, files, v4l2, fpga-dma"), std::string::npos) << message;
}

class FpgaDma : public Sources {
 protected:
  std::string ring_path() const { return (dir_ / "ring").string(); }
  std::unique_ptr<FrameSource> dma_source() const {
    SourceOptions options;
    options.kind = "fpga-dma";
    options.ring = ring_path();
    options.ring_timeout = 20ms;
    return make_source(options, rig_);
  }
  thermovis::fpga::RingGeometry rig_geometry() const {
    return thermovis::fpga::stereo_rig_geometry(kVisible, kInfrared, 3);
  }
};

TEST_F(FpgaDma, ReadsWhatTheEmulatorSideRendersIntoTheRing) {
  // The FPGA side as thermovis-fpga-emu runs it: the simulated rig renders straight into the
  // ring's slots, then commits them.
  SourceOptions sim_options;
  sim_options.scene = (thermovis::test::source_root() / "deploy/scenes/paper.yaml").string();
  auto sim = make_source(sim_options, rig_);
  thermovis::fpga::RingWriter writer(ring_path(), rig_geometry());
  auto source = dma_source();
  EXPECT_TRUE(source->self_paced());
  FrameSet frames = allocate(*source);
  FrameSet expected = allocate(*sim);
  for (std::int64_t index = 0; index < 4; ++index) {
    FrameSet slot;
    slot.images = writer.begin();
    ASSERT_TRUE(sim->fill(index, slot));
    writer.commit(static_cast<std::uint64_t>(index), 1'000 + index);
    ASSERT_TRUE(source->fill(index, frames));
    ASSERT_TRUE(sim->fill(index, expected));
    expect_equal(frames, expected);
    EXPECT_EQ(source->capture_time_ns(), 1'000 + index);
  }
  EXPECT_EQ(source->skipped(), 0u);
}

TEST_F(FpgaDma, TakesTheNewestCaptureAndCountsSkippedOnes) {
  thermovis::fpga::RingWriter writer(ring_path(), rig_geometry());
  auto source = dma_source();
  for (int n = 0; n < 3; ++n) writer.write(test_frame(n).images, static_cast<std::uint64_t>(n), n);
  FrameSet frames = allocate(*source);
  ASSERT_TRUE(source->fill(0, frames));
  expect_equal(frames, test_frame(2));
  EXPECT_EQ(source->skipped(), 2u);
  // No new capture within the timeout: an error the bridge counts as a bad capture.
  const std::string message = error_of([&] { source->fill(1, frames); });
  EXPECT_NE(message.find("no capture in ring " + ring_path()), std::string::npos) << message;
}

TEST_F(FpgaDma, FollowsARingItsWriterRecreated) {
  auto writer = std::make_unique<thermovis::fpga::RingWriter>(ring_path(), rig_geometry());
  auto source = dma_source();
  writer.reset();
  writer = std::make_unique<thermovis::fpga::RingWriter>(ring_path(), rig_geometry());
  FrameSet frames = allocate(*source);
  // The old ring stays silent: this fill times out and reopens the new one.
  EXPECT_NE(error_of([&] { source->fill(0, frames); }).find("no capture"), std::string::npos);
  writer->write(test_frame(1).images, 1, 1);
  ASSERT_TRUE(source->fill(1, frames));
  expect_equal(frames, test_frame(1));
}

TEST_F(FpgaDma, RejectsAMissingRingOrOneThatDoesNotFitTheRig) {
  std::string message = error_of([&] { dma_source(); });
  EXPECT_NE(message.find("cannot open ring " + ring_path()), std::string::npos) << message;

  thermovis::fpga::RingWriter writer(
      ring_path(), thermovis::fpga::stereo_rig_geometry(kVisible, cv::Size(32, 24)));
  message = error_of([&] { dma_source(); });
  EXPECT_NE(message.find("infrared left slots hold 32x24 MONO16, the rig's camera is 64x48"),
            std::string::npos)
      << message;

  std::ofstream(ring_path(), std::ios::trunc) << std::string(8192, 'x');
  message = error_of([&] { dma_source(); });
  EXPECT_NE(message.find("bad magic"), std::string::npos) << message;
}

TEST_F(Sources, SimPrerenderCyclesThroughTheLiveCaptures) {
  SourceOptions options;
  options.scene = (thermovis::test::source_root() / "deploy/scenes/paper.yaml").string();
  auto live = make_source(options, rig_);
  options.prerender = 3;
  auto cached = make_source(options, rig_);
  FrameSet a = allocate(*live), b = allocate(*live);
  for (std::int64_t index = 0; index < 3; ++index) {
    ASSERT_TRUE(live->fill(index, a));
    ASSERT_TRUE(cached->fill(index, b));
    expect_equal(b, a);
    ASSERT_TRUE(cached->fill(index + 3, b));  // capture index + 3 repeats capture index
    expect_equal(b, a);
  }
  ASSERT_TRUE(cached->fill(1, a));
  ASSERT_TRUE(cached->fill(2, b));
  EXPECT_FALSE(
      identical(a[Slot::infrared_left], b[Slot::infrared_left]));  // noise differs per frame
  options.prerender = -1;
  EXPECT_NE(error_of([&] { make_source(options, rig_); }).find("--prerender"), std::string::npos);
}

// While it prerenders the simulated rig says how far it is (the bridge's health, which a
// measurement waits on), counting up, and then nothing; rendering live it never prepares. 2000
// captures of the tiny rig take one or two seconds: the first look comes while it prepares.
TEST_F(Sources, SimSaysHowFarItsPrerenderIs) {
  SourceOptions options;
  options.scene = (thermovis::test::source_root() / "deploy/scenes/paper.yaml").string();
  EXPECT_EQ(make_source(options, rig_)->preparing(), "");
  options.prerender = 2000;
  auto cached = make_source(options, rig_);
  std::vector<std::string> seen;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  for (std::string what = cached->preparing();
       !what.empty() && std::chrono::steady_clock::now() < end; what = cached->preparing()) {
    if (seen.empty() || seen.back() != what) seen.push_back(what);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(cached->preparing(), "");
  ASSERT_FALSE(seen.empty()) << "2000 captures prerendered before the first look";
  int last = -1;
  for (const std::string& what : seen) {
    std::istringstream in(what);
    int done = -1;
    std::string of, rest;
    int total = 0;
    in >> done >> of >> total;
    std::getline(in, rest);
    EXPECT_EQ(of, "of") << what;
    EXPECT_EQ(total, 2000) << what;
    EXPECT_EQ(rest, " captures prerendered") << what;
    EXPECT_GT(done, last) << what;
    EXPECT_LT(done, 2000) << what;
    last = done;
  }
}

}  // namespace
