// Another DDS application reading the pipeline's frame topics, written as a user would write
// it: Fast DDS with the default participant and reader QoS (built-in transports, BEST_EFFORT,
// KEEP_LAST 1, data-sharing automatic: on this host it reads the writers' pools directly), none
// of thermovis's own settings. `thermovis bench pipeline --external-readers N` and
// tests/integration/faults start these beside the pipeline to measure what they cost it.
//
//   external_reader --domain D --mode idle|slow|crash [--hold-ms 200] [--crash-after-s 3]
//                   TOPIC...
// idle: its readers match and never take. slow: each takes one frame at a time on a loan and
// holds it --hold-ms before giving it back. crash: as slow, then SIGKILLs itself while holding
// its loans, --crash-after-s after the first frame.
#include <fastdds/dds/core/LoanableSequence.hpp>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "thermovis/framesPubSubTypes.h"

namespace fdds = eprosima::fastdds::dds;

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

// One topic's reader; take_and_hold takes one sample on a loan, runs `hold` while it holds it
// and gives it back. False when nothing was there.
struct FrameReader {
  fdds::DataReader* reader = nullptr;
  std::function<bool(fdds::DataReader*, const std::function<void()>&)> take_and_hold;
};

template <class T>
bool take_and_hold(fdds::DataReader* reader, const std::function<void()>& hold) {
  fdds::LoanableSequence<T> data;
  fdds::SampleInfoSeq infos;
  if (reader->take(data, infos, 1) != eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
    return false;
  }
  hold();
  reader->return_loan(data, infos);
  return true;
}

// The type of a pipeline frame topic (docs/topics.md).
template <class T, class PubSub>
FrameReader make_reader(fdds::DomainParticipant* participant, fdds::Subscriber* subscriber,
                        const std::string& topic_name) {
  fdds::TypeSupport type(new PubSub());
  type.register_type(participant);
  fdds::Topic* topic =
      participant->create_topic(topic_name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  FrameReader r;
  if (topic != nullptr)
    r.reader = subscriber->create_datareader(topic, fdds::DATAREADER_QOS_DEFAULT);
  r.take_and_hold = take_and_hold<T>;
  return r;
}

int usage(const char* why) {
  std::cerr << "external_reader: " << why
            << "\nusage: external_reader --domain D --mode idle|slow|crash [--hold-ms MS] "
               "[--crash-after-s S] TOPIC...\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  int domain = -1;
  std::string mode;
  int hold_ms = 200;
  double crash_after_s = 3.0;
  std::vector<std::string> topics;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--domain" && has_value) {
      domain = std::atoi(argv[++i]);
    } else if (a == "--mode" && has_value) {
      mode = argv[++i];
    } else if (a == "--hold-ms" && has_value) {
      hold_ms = std::atoi(argv[++i]);
    } else if (a == "--crash-after-s" && has_value) {
      crash_after_s = std::atof(argv[++i]);
    } else if (!a.empty() && a[0] != '-') {
      topics.push_back(a);
    } else {
      return usage(("unknown argument " + a).c_str());
    }
  }
  if (domain < 0 || domain > 232) return usage("--domain 0..232 is required");
  if (mode != "idle" && mode != "slow" && mode != "crash") return usage("--mode idle|slow|crash");
  if (topics.empty()) return usage("no topic");
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  auto* factory = fdds::DomainParticipantFactory::get_instance();
  fdds::DomainParticipant* participant = factory->create_participant(
      static_cast<fdds::DomainId_t>(domain), fdds::PARTICIPANT_QOS_DEFAULT);
  if (participant == nullptr) return usage("cannot create a participant");
  fdds::Subscriber* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  std::vector<FrameReader> readers;
  for (const std::string& name : topics) {
    if (name == "thermovis/frames/visible") {
      readers.push_back(
          make_reader<thermovis::VisibleStereoFrame, thermovis::VisibleStereoFramePubSubType>(
              participant, subscriber, name));
    } else if (name == "thermovis/frames/infrared") {
      readers.push_back(
          make_reader<thermovis::InfraredStereoFrame, thermovis::InfraredStereoFramePubSubType>(
              participant, subscriber, name));
    } else {
      readers.push_back(
          make_reader<thermovis::GridStereoFrame, thermovis::GridStereoFramePubSubType>(
              participant, subscriber, name));
    }
    if (readers.back().reader == nullptr) return usage(("cannot read " + name).c_str());
  }
  std::cout << "external_reader: " << mode << " on " << topics.size() << " topics" << std::endl;

  using Clock = std::chrono::steady_clock;
  Clock::time_point first_frame{};
  std::uint64_t taken = 0;
  while (!g_stop) {
    if (mode == "idle") {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    bool any = false;
    for (FrameReader& r : readers) {
      any |= r.take_and_hold(r.reader, [&] {
        ++taken;
        if (first_frame == Clock::time_point{}) first_frame = Clock::now();
        // Holding the loan, as an application busy with the frame does.
        std::this_thread::sleep_for(std::chrono::milliseconds(hold_ms));
        if (mode == "crash" &&
            Clock::now() - first_frame > std::chrono::duration<double>(crash_after_s)) {
          std::cout << "external_reader: crashing with a loan held after " << taken << " frames"
                    << std::endl;
          std::raise(SIGKILL);
        }
      });
    }
    if (!any) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::cout << "external_reader: took " << taken << " frames" << std::endl;
  participant->delete_contained_entities();
  factory->delete_participant(participant);
  return 0;
}
