#include "frame_source.hpp"

#include <dlfcn.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <vector>

#include "media_sources.hpp"
#include "thermovis/fpga/ring.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace thermovis::bridge {
namespace {

// FNV-1a of a file's bytes, as hex; "" when it cannot be read.
std::string file_digest(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  std::uint64_t h = 0xCBF29CE484222325ULL;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    for (std::streamsize i = 0; i < in.gcount(); ++i)
      h = (h ^ static_cast<unsigned char>(buffer[i])) * 0x100000001B3ULL;
  }
  std::ostringstream hex;
  hex << std::hex << std::setw(16) << std::setfill('0') << h;
  return hex.str();
}

// The folder of the simulator's static scene caches: --sim-cache, else $XDG_CACHE_HOME/thermovis,
// else ~/.cache/thermovis, else /tmp/thermovis-cache.
std::filesystem::path cache_folder(const std::string& option) {
  if (option != "auto") return option;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg != nullptr && *xdg != '\0')
    return std::filesystem::path(xdg) / "thermovis";
  if (const char* home = std::getenv("HOME"); home != nullptr && *home != '\0')
    return std::filesystem::path(home) / ".cache/thermovis";
  return "/tmp/thermovis-cache";
}

// The set-up cache of this executable, rig, scene and seed (sim::StaticCache): the key names the
// first three by digest, so a rebuilt simulator or an edited rig or scene never reads an old
// file (the rig adds the seed to the key itself; the file name has it so that bridges with other
// seeds keep files of their own). Empty (no cache) for --sim-cache none or when a file cannot be
// read.
sim::StaticCache static_cache(const std::string& option, const std::filesystem::path& rig_file,
                              const std::filesystem::path& scene_file, std::uint64_t seed) {
  if (option == "none") return {};
  const std::string exe = file_digest("/proc/self/exe");
  const std::string rig = file_digest(rig_file);
  const std::string scene = file_digest(scene_file);
  if (exe.empty() || rig.empty() || scene.empty()) return {};
  const std::string key = "exe " + exe + " rig " + rig + " scene " + scene;
  return {cache_folder(option) /
              ("sim-static-" + exe + rig + scene + "-seed" + std::to_string(seed) + ".bin"),
          key};
}

// Keeps the `keep` newest set-up caches of `folder` (each ~200 MB): older builds', rigs', scenes'
// and seeds' go.
void prune_caches(const std::filesystem::path& folder, std::size_t keep) {
  namespace fs = std::filesystem;
  std::error_code error;
  std::vector<std::pair<fs::file_time_type, fs::path>> caches;
  for (auto it = fs::directory_iterator(folder, error); !error && it != fs::directory_iterator();
       it.increment(error)) {
    const std::string name = it->path().filename().string();
    if (name.rfind("sim-static-", 0) != 0 || it->path().extension() != ".bin") continue;
    caches.emplace_back(it->last_write_time(error), it->path());
  }
  if (caches.size() <= keep) return;
  std::sort(caches.begin(), caches.end(), std::greater<>());
  for (std::size_t i = keep; i < caches.size(); ++i) fs::remove(caches[i].second, error);
}

// One anonymous mapping for many frames, advised for transparent huge pages. The prerendered
// captures are 1.5 GB (100 captures of the paper rig) read in turn every 2 s: in 4 KB pages
// that is 400 000 pages whose accessed bits the kernel's memory monitor (DAMON, on this kind of
// virtual machine) samples, in bursts of 10-20 ms that hold a core every 0.5 s; in 2 MB pages
// it is 800.
class FrameBlock {
 public:
  explicit FrameBlock(std::size_t bytes) {
    constexpr std::size_t kHuge = std::size_t{2} << 20;
    size_ = (bytes + kHuge - 1) / kHuge * kHuge;
    if (size_ == 0) return;
    void* p = mmap(nullptr, size_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::bad_alloc();
    data_ = static_cast<unsigned char*>(p);
    (void)madvise(data_, size_, MADV_HUGEPAGE);  // a hint: without huge pages it still works
  }
  ~FrameBlock() {
    if (data_ != nullptr) munmap(data_, size_);
  }
  FrameBlock(const FrameBlock&) = delete;
  FrameBlock& operator=(const FrameBlock&) = delete;
  unsigned char* data() const { return data_; }

 private:
  unsigned char* data_ = nullptr;
  std::size_t size_ = 0;
};

// The simulated rig. Live, every capture is rendered (about 20 ms of CPU for the street scene);
// with `prerender` N > 0, capture k shows frame k % N: N frames are rendered once, by a thread
// in the background, and each fill is a copy of frame k % N when it is ready, else a live
// render of it (the same bytes), so the first capture goes out as soon as the rig is set up.
// Moving targets repeat every N captures. The simulator's set-up comes from the cache
// (sim::StaticCache) when an earlier run left one, so a restarted bridge starts in a fraction
// of a second instead of seconds.
class SimSource final : public FrameSource {
 public:
  SimSource(const camera::Rig& rig, const SourceOptions& options)
      : sim_(make_sim(rig, options)),
        cache_(static_cast<std::size_t>(std::max<std::int64_t>(options.prerender, 0))),
        block_(cache_.size() * frame_bytes(sim_)),
        ready_(cache_.size()) {
    unsigned char* next = block_.data();
    for (sim::FrameSet& frame : cache_) {
      frame = sim_.allocate();
      for (cv::Mat& image : frame.images) {
        image = cv::Mat(image.size(), image.type(), next);
        next += image.total() * image.elemSize();
      }
    }
    if (!sim_.static_setup().note.empty())
      std::cerr << "sim source: static scene traced (" << sim_.static_setup().note << ")\n";
    if (!cache_.empty()) prerender_ = std::thread([this] { prerender(); });
  }
  ~SimSource() override {
    stop_ = true;
    if (prerender_.joinable()) prerender_.join();
  }
  SimSource(const SimSource&) = delete;
  SimSource& operator=(const SimSource&) = delete;

  std::string name() const override {
    return std::string("sim") + (sim_.static_setup().loaded ? ", static scene from cache" : "") +
           (cache_.empty() ? "" : ", " + std::to_string(cache_.size()) + " prerendered");
  }
  cv::Size visible_size() const override {
    return sim_.camera(sim::Slot::visible_left).model->image_size();
  }
  cv::Size infrared_size() const override {
    return sim_.camera(sim::Slot::infrared_left).model->image_size();
  }
  std::string preparing() const override {
    const std::size_t done = prerendered_.load(std::memory_order_acquire);
    if (done >= cache_.size()) return {};
    return std::to_string(done) + " of " + std::to_string(cache_.size()) + " captures prerendered";
  }
  bool fill(std::int64_t index, sim::FrameSet& out) override {
    if (cache_.empty()) {
      sim_.render(index, out);
      return true;
    }
    const auto k = static_cast<std::size_t>(index % static_cast<std::int64_t>(cache_.size()));
    if (!ready_[k].load(std::memory_order_acquire)) {
      sim_.render(static_cast<std::int64_t>(k), out);
      return true;
    }
    for (std::size_t i = 0; i < out.images.size(); ++i) cache_[k].images[i].copyTo(out.images[i]);
    return true;
  }

 private:
  static sim::SimulatedRig make_sim(const camera::Rig& rig, const SourceOptions& options) {
    const std::filesystem::path scene = options.scene.empty()
                                            ? runtime::shipped_file("scenes/paper.yaml")
                                            : std::filesystem::path(options.scene);
    if (options.prerender < 0) {
      throw std::runtime_error("sim source: --prerender must be 0 (render live) or a count, got " +
                               std::to_string(options.prerender));
    }
    const sim::StaticCache cache =
        options.rig_file.empty()
            ? sim::StaticCache{}
            : static_cache(options.sim_cache, options.rig_file, scene, options.seed);
    sim::SimulatedRig out(rig, runtime::load_scene(scene), options.seed, {}, cache);
    if (!cache.file.empty() && !out.static_setup().loaded)
      prune_caches(cache.file.parent_path(), 3);
    return out;
  }

  static std::size_t frame_bytes(const sim::SimulatedRig& sim) {
    std::size_t bytes = 0;
    for (const cv::Mat& image : sim.allocate().images) bytes += image.total() * image.elemSize();
    return bytes;
  }

  // Renders frames 0..N-1 into the cache, each published to fill() once complete. At the
  // normal policy even when the bridge is realtime (the manifest): it is background work, and a
  // capture it has not rendered yet is rendered live.
  void prerender() {
    const sched_param normal{};
    (void)pthread_setschedparam(pthread_self(), SCHED_OTHER, &normal);
    for (std::size_t k = 0; k < cache_.size() && !stop_; ++k) {
      sim_.render(static_cast<std::int64_t>(k), cache_[k]);
      ready_[k].store(true, std::memory_order_release);
      prerendered_.store(k + 1, std::memory_order_release);
    }
  }

  sim::SimulatedRig sim_;
  std::vector<sim::FrameSet> cache_;  // images over block_
  FrameBlock block_;
  std::vector<std::atomic<bool>> ready_;     // cache_[k] rendered (written once, then read only)
  std::atomic<std::size_t> prerendered_{0};  // frames 0..prerendered_-1 are ready
  std::atomic<bool> stop_{false};
  std::thread prerender_;
};

// Captures from an FPGA (or thermovis-fpga-emu) through the memory-mapped capture ring
// (fpga/ring.hpp). The FPGA sets the pace: each fill waits for a capture newer than the last
// one and takes the newest, so the bridge adds no queueing latency; captures it could not take
// count as skipped. A ring its writer re-created (new file at the same path) is reopened.
class FpgaDmaSource final : public FrameSource {
 public:
  FpgaDmaSource(const camera::Rig& rig, const std::string& path, std::chrono::milliseconds timeout)
      : path_(path),
        timeout_(timeout),
        expected_(fpga::stereo_rig_geometry(rig.camera(rig.visible.left).model->image_size(),
                                            rig.camera(rig.infrared.left).model->image_size())) {
    if (path.empty())
      throw std::runtime_error("fpga-dma source: --ring is required (the capture ring's path)");
    reader_ = open();
  }
  std::string name() const override { return "fpga-dma (" + path_ + ")"; }
  cv::Size visible_size() const override { return expected_.images[0].size; }
  cv::Size infrared_size() const override { return expected_.images[2].size; }
  bool self_paced() const override { return true; }
  std::optional<std::int64_t> capture_time_ns() const override { return capture_time_ns_; }
  std::uint64_t skipped() const override {
    return skipped_before_ + (reader_ ? reader_->stats().skipped : 0);
  }

  bool fill(std::int64_t /*index*/, sim::FrameSet& out) override {
    if (!reader_) {
      // The ring went away (its writer stopped): wait a timeout, so a bridge without a ring does
      // not spin, then try to open it again.
      std::this_thread::sleep_for(timeout_);
      reader_ = open();
    }
    std::uint64_t frame_seq = 0;
    std::int64_t stamp = 0;
    if (!reader_->read_into(out.images, frame_seq, stamp, timeout_)) {
      if (reader_->replaced()) {
        skipped_before_ += reader_->stats().skipped;
        reader_.reset();
        reader_ = open();
      }
      throw std::runtime_error("fpga-dma source: no capture in ring " + path_ + " for " +
                               std::to_string(timeout_.count()) + " ms");
    }
    capture_time_ns_ = stamp;
    return true;
  }

 private:
  std::unique_ptr<fpga::RingReader> open() const {
    try {
      auto reader = std::make_unique<fpga::RingReader>(path_, fpga::RingReader::Mode::latest);
      reader->require_images(expected_);
      return reader;
    } catch (const fpga::RingError& e) {
      throw std::runtime_error(std::string("fpga-dma source: ") + e.what());
    }
  }

  std::string path_;
  std::chrono::milliseconds timeout_;
  fpga::RingGeometry expected_;
  std::unique_ptr<fpga::RingReader> reader_;
  std::optional<std::int64_t> capture_time_ns_;
  std::uint64_t skipped_before_ = 0;
};

// The files and v4l2 sources live in a module of their own, loaded only when asked for: OpenCV's
// image codecs and video I/O pull in some 240 shared libraries (GStreamer, FFmpeg, GDAL, ...)
// whose loading took a restarted bridge about 0.5 s at load 7 before main() even ran.
std::unique_ptr<FrameSource> make_media_source(const SourceOptions& options,
                                               const camera::Rig& rig) {
  static void* module = [] {
    std::error_code error;
    const auto beside =
        std::filesystem::read_symlink("/proc/self/exe", error).parent_path() / kMediaModule;
    void* handle = error ? nullptr : ::dlopen(beside.c_str(), RTLD_NOW | RTLD_LOCAL);
    // Else wherever the dynamic linker looks (LD_LIBRARY_PATH, the system's folders).
    if (handle == nullptr) handle = ::dlopen(kMediaModule, RTLD_NOW | RTLD_LOCAL);
    return handle;
  }();
  if (module == nullptr) {
    const char* why = ::dlerror();
    throw std::runtime_error(options.kind + " source: cannot load " + kMediaModule +
                             " (next to the executable or on the library path): " +
                             (why != nullptr ? why : "not found"));
  }
  const auto make =
      reinterpret_cast<MediaSourceFactory>(::dlsym(module, kMediaSourceFactorySymbol));
  if (make == nullptr) {
    throw std::runtime_error(options.kind + " source: " + kMediaModule + " has no " +
                             kMediaSourceFactorySymbol);
  }
  return std::unique_ptr<FrameSource>(make(options, rig));
}

}  // namespace

std::unique_ptr<FrameSource> make_source(const SourceOptions& options, const camera::Rig& rig) {
  if (options.kind == "sim") return std::make_unique<SimSource>(rig, options);
  if (options.kind == "files" || options.kind == "v4l2") return make_media_source(options, rig);
  if (options.kind == "fpga-dma")
    return std::make_unique<FpgaDmaSource>(rig, options.ring, options.ring_timeout);
  throw std::runtime_error("unknown source '" + options.kind + "' (known: " + kSourceKinds + ")");
}

}  // namespace thermovis::bridge
