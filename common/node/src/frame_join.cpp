#include "thermovis/node/frame_join.hpp"

#include <iostream>

namespace thermovis::node {

bool FrameSequence::admit(std::uint64_t seq, std::int64_t capture_ns, HealthReporter& health) {
  const std::uint64_t last_seq = order_.last_seq();
  last_ = order_.check(seq, capture_ns);
  switch (last_) {
    case FrameOrder::Verdict::repeated:
      ++repeated_;  // a frame seen before: never processed twice
      return false;
    case FrameOrder::Verdict::stale:
      ++stale_;
      health.bad_input(what_ + " " + std::to_string(seq) + " captured before frame " +
                       std::to_string(last_seq) + ": out of order, dropped");
      return false;
    case FrameOrder::Verdict::restarted:
      std::cerr << service_ << ": " << what_ << "s start again at " << seq << " after " << last_seq
                << " with a later capture time (their writer restarted)" << std::endl;
      return true;
    case FrameOrder::Verdict::next:
      return true;
  }
  return false;
}

}  // namespace thermovis::node
