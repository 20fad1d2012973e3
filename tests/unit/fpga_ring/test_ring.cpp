// The capture ring through a real mapped file: captures round-trip byte for byte with their
// stamps, a reader that falls behind skips what the writer overwrote and counts it, a copy torn
// by a writer lapping the reader is discarded, and bad rings give errors naming what is wrong.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <thread>

#include "thermovis/fpga/ring.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/test/images.hpp"

namespace {

namespace fs = std::filesystem;
using thermovis::fpga::RingCapture;
using thermovis::fpga::RingError;
using thermovis::fpga::RingGeometry;
using thermovis::fpga::RingReader;
using thermovis::fpga::RingWriter;
using namespace std::chrono_literals;

const cv::Size kVisible{40, 24};
const cv::Size kInfrared{20, 12};

// Seeded captures that differ in every image and every capture.
std::array<cv::Mat, 4> make_images(int capture) {
  return thermovis::test::seeded_capture(static_cast<std::uint64_t>(1000 + capture), kVisible,
                                         kInfrared);
}

void expect_capture(const RingCapture& got, int capture) {
  const auto want = make_images(capture);
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_TRUE(thermovis::test::identical(got.images[i], want[i])) << "image " << i;
  EXPECT_EQ(got.frame_seq, static_cast<std::uint64_t>(500 + capture));
  EXPECT_EQ(got.capture_time_ns, 1'700'000'000'000'000'000LL + capture * 20'000'000LL);
}

void write_capture(RingWriter& writer, int capture) {
  writer.write(make_images(capture), static_cast<std::uint64_t>(500 + capture),
               1'700'000'000'000'000'000LL + capture * 20'000'000LL);
}

std::string error_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const RingError& e) {
    return e.what();
  }
  return "(no error)";
}

class Ring : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = thermovis::test::temp_dir("fpga-ring"); }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name = "ring") const { return (dir_ / name).string(); }
  static RingGeometry geometry(std::uint32_t slots) {
    return thermovis::fpga::stereo_rig_geometry(kVisible, kInfrared, slots);
  }
  fs::path dir_;
};

TEST_F(Ring, CapturesRoundTripThroughTheMappedFile) {
  RingWriter writer(path(), geometry(3));
  RingReader reader(path());
  EXPECT_EQ(reader.geometry().slot_count, 3u);
  EXPECT_EQ(reader.geometry().images[0].size, kVisible);
  EXPECT_EQ(reader.geometry().images[3].format, thermovis::fpga::RingPixelFormat::mono16);
  RingCapture capture;
  EXPECT_FALSE(reader.read(capture, 1ms));  // nothing written yet
  for (int n = 0; n < 7; ++n) {             // more than the slots: the ring wraps
    write_capture(writer, n);
    ASSERT_TRUE(reader.read(capture, 1s));
    expect_capture(capture, n);
    EXPECT_EQ(capture.ring_index, static_cast<std::uint64_t>(n));
  }
  EXPECT_EQ(writer.written(), 7u);
  EXPECT_EQ(reader.stats().delivered, 7u);
  EXPECT_EQ(reader.stats().skipped, 0u);
  EXPECT_EQ(reader.stats().torn, 0u);
  // The file has the documented size: header page + slots of whole pages.
  const auto bytes = fs::file_size(path());
  EXPECT_EQ(bytes % 4096, 0u);
  EXPECT_GE(bytes, 4096u + 3u * (2u * 40 * 24 * 3 + 2u * 20 * 12 * 2 + 64));
}

TEST_F(Ring, PosixSharedMemoryNameWorksAndIsRemoved) {
  const std::string name = "thermovis-test-ring-" + std::to_string(::getpid());
  {
    RingWriter writer("shm:" + name, geometry(2));
    EXPECT_TRUE(fs::exists("/dev/shm/" + name));
    RingReader reader("shm:" + name);
    write_capture(writer, 4);
    RingCapture capture;
    ASSERT_TRUE(reader.read(capture, 1s));
    expect_capture(capture, 4);
    writer.remove();
    EXPECT_TRUE(reader.replaced());
  }
  EXPECT_FALSE(fs::exists("/dev/shm/" + name));
}

TEST_F(Ring, ReaderStartsAtTheNewestCapture) {
  RingWriter writer(path(), geometry(4));
  write_capture(writer, 0);
  write_capture(writer, 1);
  RingReader reader(path());
  RingCapture capture;
  EXPECT_FALSE(reader.read(capture, 1ms));
  write_capture(writer, 2);
  ASSERT_TRUE(reader.read(capture, 1s));
  expect_capture(capture, 2);
  EXPECT_EQ(reader.stats().skipped, 0u);
}

TEST_F(Ring, OverrunSkipsWhatTheWriterOverwroteAndCountsIt) {
  RingWriter writer(path(), geometry(3));
  RingReader reader(path(), RingReader::Mode::next);
  for (int n = 0; n < 6; ++n) write_capture(writer, n);
  // Written 0..5 into 3 slots: 0..2 are overwritten, and capture 3's slot is the one the
  // writer fills next (capture 6), so the oldest capture safe to copy is 6 - 3 + 1 = 4.
  RingCapture capture;
  ASSERT_TRUE(reader.read(capture, 1s));
  expect_capture(capture, 4);
  EXPECT_EQ(reader.stats().skipped, 4u);
  ASSERT_TRUE(reader.read(capture, 1s));
  expect_capture(capture, 5);
  EXPECT_FALSE(reader.read(capture, 1ms));
  EXPECT_EQ(reader.stats().delivered, 2u);
  EXPECT_EQ(reader.stats().skipped, 4u);
}

TEST_F(Ring, LatestModeTakesTheNewestAndCountsTheRest) {
  RingWriter writer(path(), geometry(4));
  RingReader reader(path(), RingReader::Mode::latest);
  for (int n = 0; n < 3; ++n) write_capture(writer, n);
  RingCapture capture;
  ASSERT_TRUE(reader.read(capture, 1s));
  expect_capture(capture, 2);
  EXPECT_EQ(reader.stats().skipped, 2u);
  write_capture(writer, 3);
  ASSERT_TRUE(reader.read(capture, 1s));
  expect_capture(capture, 3);
  EXPECT_EQ(reader.stats().skipped, 2u);
}

TEST_F(Ring, CopyTornByAWriterLappingTheReaderIsDiscarded) {
  RingWriter writer(path(), geometry(2));
  RingReader reader(path());
  write_capture(writer, 0);
  bool lapped = false;
  reader.set_after_copy_hook([&] {
    if (lapped) return;
    lapped = true;
    // While the reader copies capture 0 (slot 0), the writer commits capture 1 (slot 1) and
    // starts capture 2, which reuses slot 0.
    write_capture(writer, 1);
    auto views = writer.begin();
    views[0].setTo(cv::Scalar::all(7));
  });
  RingCapture capture;
  ASSERT_TRUE(reader.read(capture, 1s));
  expect_capture(capture, 1);  // the torn copy of 0 was discarded, 1 delivered instead
  EXPECT_EQ(reader.stats().torn, 1u);
  EXPECT_EQ(reader.stats().skipped, 1u);
  EXPECT_EQ(reader.stats().delivered, 1u);
  writer.commit(502, 0);
  ASSERT_TRUE(reader.read(capture, 1s));
  EXPECT_EQ(capture.frame_seq, 502u);
  EXPECT_EQ(cv::countNonZero(capture.images[0].reshape(1) != 7), 0);
}

TEST_F(Ring, ConcurrentWriterNeverDeliversMixedCaptures) {
  // A writer thread laps a 2-slot ring as fast as it can; every capture fills all its pixels
  // with its own number, so any torn copy that got through would show two numbers.
  RingWriter writer(path(), geometry(2));
  RingReader reader(path(), RingReader::Mode::next);
  std::atomic<bool> stop{false};
  std::thread producer([&] {
    for (std::uint64_t n = 0; !stop.load(); ++n) {
      auto views = writer.begin();
      for (auto& view : views) view.setTo(cv::Scalar::all(static_cast<double>(n % 200)));
      writer.commit(n, static_cast<std::int64_t>(n));
    }
  });
  RingCapture capture;
  int delivered = 0;
  std::uint64_t last = 0;
  for (int i = 0; i < 200; ++i) {
    if (!reader.read(capture, 1s)) break;
    const double value = static_cast<double>(capture.frame_seq % 200);
    for (const auto& image : capture.images) {
      double low = 0, high = 0;
      cv::minMaxLoc(image.reshape(1), &low, &high);
      ASSERT_EQ(low, value) << "capture " << capture.frame_seq;
      ASSERT_EQ(high, value) << "capture " << capture.frame_seq;
    }
    if (delivered > 0) {
      EXPECT_GT(capture.frame_seq, last);
    }
    last = capture.frame_seq;
    ++delivered;
  }
  stop = true;
  producer.join();
  EXPECT_EQ(delivered, 200);
  const auto stats = reader.stats();
  EXPECT_EQ(stats.delivered, 200u);
  // Every capture up to the last delivered one was either delivered or counted as skipped.
  EXPECT_EQ(stats.delivered + stats.skipped, last + 1);
}

TEST_F(Ring, MissingRingNamesThePath) {
  const std::string message = error_of([&] { RingReader reader(path("absent")); });
  EXPECT_NE(message.find(path("absent")), std::string::npos) << message;
  EXPECT_NE(message.find("No such file"), std::string::npos) << message;
}

TEST_F(Ring, BadHeadersAreRejectedWithTheReason) {
  {  // too small for a header
    std::ofstream(path("small")) << "not a ring";
    const std::string message = error_of([&] { RingReader reader(path("small")); });
    EXPECT_NE(message.find("too small"), std::string::npos) << message;
  }
  {  // a page of zeros: no magic
    std::ofstream out(path("zeros"), std::ios::binary);
    const std::string zeros(8192, '\0');
    out.write(zeros.data(), static_cast<std::streamsize>(zeros.size()));
    out.close();
    const std::string message = error_of([&] { RingReader reader(path("zeros")); });
    EXPECT_NE(message.find("bad magic"), std::string::npos) << message;
    EXPECT_NE(message.find(path("zeros")), std::string::npos) << message;
  }
  {  // another version
    RingWriter writer(path("version"), geometry(2));
    std::fstream file(path("version"), std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(8);
    const std::uint32_t version = 99;
    file.write(reinterpret_cast<const char*>(&version), sizeof(version));
    file.close();
    const std::string message = error_of([&] { RingReader reader(path("version")); });
    EXPECT_NE(message.find("version 99"), std::string::npos) << message;
  }
  {  // truncated: the header describes more slots than the file holds
    RingWriter writer(path("short"), geometry(3));
    fs::resize_file(path("short"), 4096 * 2);
    const std::string message = error_of([&] { RingReader reader(path("short")); });
    EXPECT_NE(message.find("truncated"), std::string::npos) << message;
  }
  {  // an image layout that runs past its slot
    RingWriter writer(path("layout"), geometry(2));
    std::fstream file(path("layout"), std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(48 + 2 * 32 + 16);  // infrared left's offset_bytes
    const std::uint64_t offset = 1ULL << 40;
    file.write(reinterpret_cast<const char*>(&offset), sizeof(offset));
    file.close();
    const std::string message = error_of([&] { RingReader reader(path("layout")); });
    EXPECT_NE(message.find("infrared left image layout"), std::string::npos) << message;
  }
}

TEST_F(Ring, MismatchedImagesAreNamed) {
  RingWriter writer(path(), geometry(2));
  RingReader reader(path());
  const std::string message = error_of([&] {
    reader.require_images(thermovis::fpga::stereo_rig_geometry(kVisible, {64, 48}));
  });
  EXPECT_NE(message.find("infrared left slots hold 20x12 MONO16"), std::string::npos) << message;
  EXPECT_NE(message.find("64x48"), std::string::npos) << message;
  EXPECT_NO_THROW(reader.require_images(geometry(7)));  // slot count aside

  auto images = make_images(0);
  images[1] = cv::Mat(kVisible, CV_8UC1, cv::Scalar(0));
  const std::string write_error = error_of([&] { writer.write(images, 0, 0); });
  EXPECT_NE(write_error.find("visible right"), std::string::npos) << write_error;
  EXPECT_EQ(writer.written(), 0u);
}

TEST_F(Ring, BadGeometryIsRejected) {
  EXPECT_NE(error_of([&] { RingWriter writer(path(), geometry(1)); }).find("at least 2 slots"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              RingWriter writer(path(), thermovis::fpga::stereo_rig_geometry({0, 10}, kInfrared));
            }).find("visible left image size 0x10"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              RingWriter writer((dir_ / "no/such/dir/ring").string(), geometry(2));
            }).find("cannot create ring"),
            std::string::npos);
}

}  // namespace
