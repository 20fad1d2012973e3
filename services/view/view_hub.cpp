#include "view_hub.hpp"

#include <algorithm>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "thermovis/metrics/percentile.hpp"

namespace thermovis::view {
namespace {

std::size_t index_of(display::View view) { return static_cast<std::size_t>(view); }

nlohmann::json stats(const std::vector<double>& values) {
  return {{"p50_ms", metrics::percentile(values, 50)},
          {"p95_ms", metrics::percentile(values, 95)},
          {"max_ms", values.empty() ? 0.0 : *std::max_element(values.begin(), values.end())}};
}

}  // namespace

std::shared_ptr<EncodedFrame> encode_jpeg(const cv::Mat& image, int quality) {
  auto frame = std::make_shared<EncodedFrame>();
  std::vector<unsigned char> buffer;
  cv::imencode(".jpg", image, buffer, {cv::IMWRITE_JPEG_QUALITY, quality});
  frame->jpeg.assign(buffer.begin(), buffer.end());
  return frame;
}

void ViewHub::publish(display::View view, std::shared_ptr<const EncodedFrame> frame) {
  {
    std::lock_guard lock(mutex_);
    frames_[index_of(view)] = std::move(frame);
  }
  changed_.notify_all();
}

void ViewHub::set_targets_json(std::string json) {
  std::lock_guard lock(mutex_);
  targets_json_ = std::move(json);
}

void ViewHub::set_status_json(std::string json) {
  std::lock_guard lock(mutex_);
  status_json_ = std::move(json);
}

bool ViewHub::wanted(display::View view, Clock::duration within) const {
  std::lock_guard lock(mutex_);
  const auto at = wanted_at_[index_of(view)];
  return at != Clock::time_point{} && Clock::now() - at < within;
}

void ViewHub::note_composed(std::int64_t capture_time_ns, std::int64_t range_ns,
                            std::int64_t encoded_ns) {
  std::lock_guard lock(mutex_);
  composed_.push_back({capture_time_ns, range_ns, encoded_ns});
  while (composed_.size() > kMaxComposed) composed_.pop_front();
}

void ViewHub::want(display::View view) {
  std::lock_guard lock(mutex_);
  wanted_at_[index_of(view)] = Clock::now();
}

std::shared_ptr<const EncodedFrame> ViewHub::wait_frame(display::View view, std::uint64_t after,
                                                        std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  const auto i = index_of(view);
  wanted_at_[i] = Clock::now();
  changed_.wait_for(lock, timeout,
                    [&] { return stopped_ || (frames_[i] && frames_[i]->number > after); });
  if (stopped_ || !frames_[i] || frames_[i]->number <= after) return nullptr;
  return frames_[i];
}

std::shared_ptr<const EncodedFrame> ViewHub::latest(display::View view) const {
  std::lock_guard lock(mutex_);
  return frames_[index_of(view)];
}

std::string ViewHub::targets_json() const {
  std::lock_guard lock(mutex_);
  return targets_json_;
}

std::string ViewHub::status_json() const {
  std::lock_guard lock(mutex_);
  return status_json_;
}

void ViewHub::add_display_samples(const std::vector<DisplaySample>& samples) {
  std::lock_guard lock(mutex_);
  for (const DisplaySample& s : samples) {
    // The composition of that capture (the stamp keeps 100 us of the capture time).
    const auto it = std::find_if(composed_.rbegin(), composed_.rend(), [&](const Composed& c) {
      return std::llabs(c.capture_time_ns - s.capture_time_ns) < 100'000;
    });
    if (it == composed_.rend() || s.shown_ns < s.capture_time_ns) continue;
    measured_.push_back({static_cast<double>(s.shown_ns - s.capture_time_ns) / 1e6,
                         static_cast<double>(it->range_ns - it->capture_time_ns) / 1e6,
                         static_cast<double>(it->encoded_ns - it->range_ns) / 1e6,
                         static_cast<double>(s.shown_ns - it->encoded_ns) / 1e6});
    while (measured_.size() > kMaxMeasured) measured_.pop_front();
  }
}

std::string ViewHub::display_latency_json() const {
  std::lock_guard lock(mutex_);
  std::vector<double> total, pipeline, viewer, browser;
  for (const Measured& m : measured_) {
    total.push_back(m.capture_to_shown_ms);
    pipeline.push_back(m.capture_to_range_ms);
    viewer.push_back(m.range_to_encoded_ms);
    browser.push_back(m.encoded_to_shown_ms);
  }
  return nlohmann::json{{"frames", measured_.size()},
                        {"capture_to_shown", stats(total)},
                        {"capture_to_range", stats(pipeline)},
                        {"range_to_encoded", stats(viewer)},
                        {"encoded_to_shown", stats(browser)}}
      .dump();
}

void ViewHub::stop() {
  {
    std::lock_guard lock(mutex_);
    stopped_ = true;
  }
  changed_.notify_all();
}

bool ViewHub::stopped() const {
  std::lock_guard lock(mutex_);
  return stopped_;
}

}  // namespace thermovis::view
