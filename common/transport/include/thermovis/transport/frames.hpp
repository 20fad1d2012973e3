#pragma once
// Frame topics on two wires. A plain frame type (VisibleStereoFrame, InfraredStereoFrame,
// GridStereoFrame) is as large as its largest image (GridStereoFrame 13.1 MB) and goes by
// data-sharing on its writer's host: no copy, and the pages of a pool slot that an image does
// not fill are never touched. Across a host link the plain sample is serialised whole; there
// the topic's packed twin "<topic>/packed" (PackedStereoFrame) carries the same header and only
// the image's bytes.
//
// FrameWriter<Plain> writes a plain frame topic and fills its twin only while a reader of the
// twin is matched, so a frame crosses a link only when a process on the other side asked for
// it. FrameReader<Plain> reads the plain topic or the twin, as its participant's
// FrameTransport says (services: --frame-transport), and hands out the plain type either way:
// the services' stage code does not know which wire its frames came by.
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "thermovis/frames.h"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::transport {

// "<frame_topic>/packed".
std::string packed_topic(const std::string& frame_topic);

// The header and the image bytes (height x step per eye) of a plain frame. Throws
// std::invalid_argument when the header's height x step exceeds the frame's capacity.
void pack(const VisibleStereoFrame& from, PackedStereoFrame& to);
void pack(const InfraredStereoFrame& from, PackedStereoFrame& to);
void pack(const GridStereoFrame& from, PackedStereoFrame& to);

// A packed frame into a plain one (only the header and the bytes it carries are written).
// Throws std::invalid_argument naming what is wrong: an eye whose byte count is not the
// header's height x step, an image larger than the plain type holds, the right eye missing
// without EYES_LEFT, or eyes other than both for a raw frame type.
void unpack(const PackedStereoFrame& from, VisibleStereoFrame& to);
void unpack(const PackedStereoFrame& from, InfraredStereoFrame& to);
void unpack(const PackedStereoFrame& from, GridStereoFrame& to);

// A plain frame topic's writer and its packed twin's.
template <class Plain>
class FrameWriter {
 public:
  FrameWriter(Participant& participant, const std::string& topic, const TopicQos& qos)
      : plain_(participant, topic, qos),
        packed_(participant, packed_topic(topic), packed_twin_qos(qos)) {}

  // A sample of the plain topic's pool (Writer::loan).
  Loan<Plain> loan() { return plain_.loan(); }

  // Publishes the loaned frame on the plain topic, then a packed copy of it on the twin when a
  // reader of the twin is matched. Either failure is thrown (the plain frame is out by then
  // when only the twin failed).
  void publish(Loan<Plain>&& loan) {
    const Plain* sample = loan.get();
    plain_.publish(std::move(loan));
    // The writer reuses the slot only at a later loan: the published sample stays readable.
    if (packed_.counters().matched == 0) return;
    pack(*sample, packed_sample_);
    packed_.write(packed_sample_);
  }

  // Readers matched on the plain topic and on the twin.
  std::uint32_t readers() const { return plain_.counters().matched + packed_.counters().matched; }
  TopicCountersSnapshot counters() const { return plain_.counters(); }
  TopicCountersSnapshot packed_counters() const { return packed_.counters(); }
  const std::string& topic_name() const { return plain_.topic_name(); }
  bool wait_for_readers(std::uint32_t count, std::chrono::milliseconds timeout) {
    return plain_.wait_for_readers(count, timeout);
  }
  // Both writers anew (Writer::recreate).
  void recreate() {
    plain_.recreate();
    packed_.recreate();
  }

 private:
  Writer<Plain> plain_;
  Writer<PackedStereoFrame> packed_;
  PackedStereoFrame packed_sample_;  // reused: its sequences keep their capacity
};

// Frames taken from a FrameReader, valid until destruction (plain ones pinned in the writer's
// pool, packed ones unpacked into buffers of the reader).
template <class Plain>
class FrameSamples {
 public:
  std::size_t size() const { return plain_ ? plain_->size() : unpacked_.size(); }
  bool empty() const { return size() == 0; }
  const Plain& operator[](std::size_t i) const { return plain_ ? (*plain_)[i] : *unpacked_[i]; }
  // Samples::still_valid for plain frames; an unpacked frame is this process's own copy.
  bool still_valid(std::size_t i) const { return plain_ ? plain_->still_valid(i) : true; }

 private:
  template <class>
  friend class FrameReader;
  FrameSamples() = default;
  std::optional<Samples<Plain>> plain_;
  std::vector<std::shared_ptr<const Plain>> unpacked_;
};

// A reader of a plain frame topic or of its packed twin, by the participant's FrameTransport.
template <class Plain>
class FrameReader {
 public:
  // Called with "<topic>: frame <seq>: <what is wrong>" for a packed sample that does not
  // unpack; it is left out of take()'s frames (bad input: the service counts it and goes on).
  using BadFrame = std::function<void(const std::string&)>;

  FrameReader(Participant& participant, const std::string& topic, const TopicQos& qos,
              BadFrame bad_frame = {})
      : bad_frame_(std::move(bad_frame)) {
    if (participant.state()->frame_transport == FrameTransport::packed) {
      packed_.emplace(participant, packed_topic(topic), packed_twin_qos(qos));
    } else {
      plain_.emplace(participant, topic, qos);
    }
  }

  // Takes every available frame (at most max_samples), without waiting.
  FrameSamples<Plain> take(std::int32_t max_samples = -1) {
    FrameSamples<Plain> out;
    if (plain_) {
      out.plain_.emplace(plain_->take(max_samples));
      return out;
    }
    auto samples = packed_->take(max_samples);
    for (std::size_t i = 0; i < samples.size(); ++i) {
      std::shared_ptr<Plain> frame = free_buffer();
      try {
        unpack(samples[i], *frame);
        out.unpacked_.push_back(std::move(frame));
      } catch (const std::invalid_argument& e) {
        ++bad_;
        const std::string why =
            packed_->topic_name() + ": frame " + std::to_string(samples[i].seq()) + ": " + e.what();
        if (bad_frame_) {
          bad_frame_(why);
        } else {
          std::cerr << "transport: " << why << std::endl;
        }
      }
    }
    return out;
  }

  bool wait_for_data(std::chrono::nanoseconds timeout) {
    return plain_ ? plain_->wait_for_data(timeout) : packed_->wait_for_data(timeout);
  }
  bool wait_for_writers(std::uint32_t count, std::chrono::milliseconds timeout) {
    return plain_ ? plain_->wait_for_writers(count, timeout)
                  : packed_->wait_for_writers(count, timeout);
  }
  TopicCountersSnapshot counters() const {
    return plain_ ? plain_->counters() : packed_->counters();
  }
  // The topic read: the plain one or its twin.
  const std::string& topic_name() const {
    return plain_ ? plain_->topic_name() : packed_->topic_name();
  }
  bool packed() const { return packed_.has_value(); }
  // Packed samples left out because they did not unpack.
  std::uint64_t bad_frames() const { return bad_; }

 private:
  // A buffer no FrameSamples holds any more, or a new one (frames are large: reused).
  std::shared_ptr<Plain> free_buffer() {
    for (const auto& b : buffers_)
      if (b.use_count() == 1) return b;
    buffers_.push_back(std::make_shared<Plain>());
    return buffers_.back();
  }

  BadFrame bad_frame_;
  std::optional<Reader<Plain>> plain_;
  std::optional<Reader<PackedStereoFrame>> packed_;
  std::vector<std::shared_ptr<Plain>> buffers_;
  std::uint64_t bad_ = 0;
};

}  // namespace thermovis::transport
