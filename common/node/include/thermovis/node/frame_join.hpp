#pragma once
// Joining the messages of two topics that belong to one capture (the same seq), and the order
// check every service makes on the frames it takes. One implementation for every service:
//  - rectify-fuse joins each visible capture with its infrared partner;
//  - detect joins a rectified infrared frame with its fused image (--hog);
//  - match joins each detection array with the rectified pairs of its capture.
// A writer's frames come in seq order, so an item later than the one wanted means the wanted
// one will never come (it was dropped upstream or superseded): the join gives up at once
// instead of waiting out its timeout.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <utility>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/health.hpp"

namespace thermovis::node {

// The last `capacity` items of a topic, in the order taken, by seq.
template <class Item>
class SeqBuffer {
 public:
  enum class Lookup { found, pending, passed };

  explicit SeqBuffer(std::size_t capacity) : capacity_(capacity == 0 ? 1 : capacity) {}

  void push(std::uint64_t seq, Item item) {
    items_.emplace_back(seq, std::move(item));
    while (items_.size() > capacity_) items_.pop_front();
  }
  // found: `item` points at it (valid until the next push or clear); passed: a later seq is
  // here, so it will not come; pending: it may still come.
  Lookup find(std::uint64_t seq, const Item*& item) const {
    item = nullptr;
    for (const auto& [s, i] : items_) {
      if (s == seq) {
        item = &i;
        return Lookup::found;
      }
    }
    return !items_.empty() && items_.back().first > seq ? Lookup::passed : Lookup::pending;
  }
  // Drops the items up to and including `seq` (consumed, or never to be joined).
  void drop_through(std::uint64_t seq) {
    while (!items_.empty() && items_.front().first <= seq) items_.pop_front();
  }
  void clear() { items_.clear(); }
  bool empty() const { return items_.empty(); }
  std::size_t size() const { return items_.size(); }

 private:
  std::size_t capacity_;
  std::deque<std::pair<std::uint64_t, Item>> items_;
};

// Waits up to `timeout` for `seq` in `buffer`: between looks, `refill(wait)` waits at most
// `wait` for the other topic's data and pushes what it took. Returns the item or nullptr (it
// will not come, the timeout passed, or `stop()` said so).
template <class Item>
const Item* join(SeqBuffer<Item>& buffer, std::uint64_t seq, std::chrono::milliseconds timeout,
                 const std::function<void(std::chrono::milliseconds)>& refill,
                 const std::function<bool()>& stop) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (true) {
    const Item* item = nullptr;
    switch (buffer.find(seq, item)) {
      case SeqBuffer<Item>::Lookup::found:
        return item;
      case SeqBuffer<Item>::Lookup::passed:
        return nullptr;
      case SeqBuffer<Item>::Lookup::pending:
        break;
    }
    const auto now = std::chrono::steady_clock::now();
    if (now >= until || stop()) return nullptr;
    refill(std::min(std::chrono::milliseconds(2),
                    std::chrono::ceil<std::chrono::milliseconds>(until - now)));
  }
}

// FrameOrder's verdict turned into what every service does with it: a repeated frame is skipped
// and counted, a stale one (captured before the last) is reported as bad input, a writer that
// restarted is logged and followed.
class FrameSequence {
 public:
  // service: for the log ("thermovis-detect"); what: the frames ("rectified infrared frame").
  FrameSequence(std::string service, std::string what)
      : service_(std::move(service)), what_(std::move(what)) {}
  // True when the frame is to be processed (the next one, or the first after a restart).
  bool admit(std::uint64_t seq, std::int64_t capture_ns, HealthReporter& health);
  // The verdict of the last admit: restarted tells a caller to forget what it kept.
  FrameOrder::Verdict last_verdict() const { return last_; }
  std::uint64_t repeated() const { return repeated_; }
  std::uint64_t stale() const { return stale_; }

 private:
  std::string service_, what_;
  FrameOrder order_;
  FrameOrder::Verdict last_ = FrameOrder::Verdict::next;
  std::uint64_t repeated_ = 0, stale_ = 0;
};

}  // namespace thermovis::node
