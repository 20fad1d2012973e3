#include "thermovis/transport/endpoint.hpp"

#include <fastrtps/utils/IPLocator.h>

#include <atomic>
#include <chrono>
#include <iostream>
#include <stdexcept>
#include <thread>
#include <utility>

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>

#include "pool_lifetime.hpp"

namespace thermovis::transport {

namespace dds = eprosima::fastdds::dds;

namespace {

// When this process last wrote a frame (steady clock, ns since its epoch; 0: never).
std::atomic<std::int64_t> last_frame_write_ns{0};

std::int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

void MatchedCount::set(std::uint32_t count, TopicCounters& counters) {
  {
    const std::lock_guard lock(mutex_);
    count_ = count;
  }
  counters.matched = count;
  changed_.notify_all();
}

bool MatchedCount::wait_at_least(std::uint32_t count, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] { return count_ >= count; });
}

namespace {

std::string return_code_name(const ReturnCode_t& code) {
  switch (code()) {
    case ReturnCode_t::RETCODE_OK:
      return "OK";
    case ReturnCode_t::RETCODE_ERROR:
      return "ERROR";
    case ReturnCode_t::RETCODE_UNSUPPORTED:
      return "UNSUPPORTED";
    case ReturnCode_t::RETCODE_BAD_PARAMETER:
      return "BAD_PARAMETER";
    case ReturnCode_t::RETCODE_PRECONDITION_NOT_MET:
      return "PRECONDITION_NOT_MET";
    case ReturnCode_t::RETCODE_OUT_OF_RESOURCES:
      return "OUT_OF_RESOURCES";
    case ReturnCode_t::RETCODE_NOT_ENABLED:
      return "NOT_ENABLED";
    case ReturnCode_t::RETCODE_TIMEOUT:
      return "TIMEOUT";
    case ReturnCode_t::RETCODE_NO_DATA:
      return "NO_DATA";
    case ReturnCode_t::RETCODE_ILLEGAL_OPERATION:
      return "ILLEGAL_OPERATION";
    default:
      return "code " + std::to_string(code());
  }
}

}  // namespace

// Both sides' DDS callbacks: matching and DEADLINE statuses into the endpoint's counters.
class EndpointBase::Listener : public dds::DataWriterListener, public dds::DataReaderListener {
 public:
  Listener(std::shared_ptr<TopicCounters> counters, std::shared_ptr<MatchedCount> matched)
      : counters_(std::move(counters)), matched_(std::move(matched)) {}

  void on_publication_matched(dds::DataWriter*,
                              const dds::PublicationMatchedStatus& status) override {
    matched_->set(static_cast<std::uint32_t>(status.current_count), *counters_);
  }
  void on_subscription_matched(dds::DataReader*,
                               const dds::SubscriptionMatchedStatus& status) override {
    matched_->set(static_cast<std::uint32_t>(status.current_count), *counters_);
  }
  void on_offered_deadline_missed(dds::DataWriter*,
                                  const dds::OfferedDeadlineMissedStatus& status) override {
    counters_->offered_deadline_missed = static_cast<std::uint32_t>(status.total_count);
  }
  void on_requested_deadline_missed(dds::DataReader*,
                                    const dds::RequestedDeadlineMissedStatus& status) override {
    counters_->requested_deadline_missed = static_cast<std::uint32_t>(status.total_count);
  }

 private:
  std::shared_ptr<TopicCounters> counters_;
  std::shared_ptr<MatchedCount> matched_;
};

EndpointBase::EndpointBase(Participant& participant, const std::string& topic,
                           const dds::TypeSupport& type, const TopicQos& qos)
    : participant_(participant.state()),
      topic_(topic),
      qos_(qos),
      counters_(std::make_shared<TopicCounters>()),
      matched_(std::make_shared<MatchedCount>()),
      listener_(std::make_unique<Listener>(counters_, matched_)) {
  if (qos.kind == TopicKind::frame && !type->is_plain()) {
    throw std::invalid_argument("frame topic '" + topic + "': type " + type.get_type_name() +
                                " is not plain, it cannot be delivered by data-sharing");
  }
}

EndpointBase::~EndpointBase() = default;  // here, where Listener is complete

// ---------------------------------------------------------------------------------------------
// Writer

WriterBase::WriterBase(Participant& participant, const std::string& topic,
                       const dds::TypeSupport& type, const TopicQos& qos)
    : EndpointBase(participant, topic, type, qos), type_(type) {
  create();
}

void WriterBase::create() {
  dds::Topic* dds_topic = participant_->topic(topic_, type_);
  const dds::StatusMask mask = dds::StatusMask::publication_matched()
                               << dds::StatusMask::offered_deadline_missed();
  dds::DataWriterQos dds_qos = writer_qos(qos_);
  if ((qos_.kind == TopicKind::frame || qos_.kind == TopicKind::packed_frame) &&
      !participant_->frame_flow_controller.empty()) {
    // Profiles for other hosts (udp.xml): frames leave through the participant's bandwidth
    // limit, from the flow controller's thread, so a 13.1 MB sample is spread over time
    // instead of overflowing the receiver's socket buffer.
    dds_qos.publish_mode().kind = dds::ASYNCHRONOUS_PUBLISH_MODE;
    dds_qos.publish_mode().flow_controller_name = participant_->frame_flow_controller.c_str();
  }
  writer_ = participant_->publisher->create_datawriter(dds_topic, dds_qos, listener_.get(), mask);
  if (writer_ == nullptr) {
    throw std::runtime_error("cannot create DDS writer on '" + topic_ + "' (see the Fast DDS log)");
  }
}

WriterBase::~WriterBase() { destroy(); }

void WriterBase::recreate() {
  if (writer_ != nullptr) {
    if (!delete_writer()) {
      writer_->set_listener(listener_.get());
      throw std::runtime_error("cannot recreate the writer of '" + topic_ +
                               "': this process still holds samples loaned from it");
    }
    matched_->set(0, *counters_);
  }
  create();
}

void WriterBase::wait_for_frame_drain() const {
  // A data-sharing reader still holding a loan of this writer's last frames when the writer is
  // deleted crashes when it returns the loan: Fast DDS 2.9 hands it back through the pool object
  // it freed at the unmatch (SampleLoanManager::return_loan -> IPayloadPool::release_payload).
  // So a frame writer with readers is deleted only once they have had kFrameDrain since this
  // process's last frame to finish with it (the first writer deleted waits, the others find
  // the time passed). Killed processes do not get here; their readers drop them only at the end
  // of the lease (10 s), long after any loan is returned.
  if (qos_.kind != TopicKind::frame) return;
  dds::PublicationMatchedStatus status;
  const std::int64_t last = last_frame_write_ns.load();
  if (last != 0 && writer_->get_publication_matched_status(status) == ReturnCode_t::RETCODE_OK &&
      status.current_count > 0) {
    const std::int64_t wait_ns =
        last + std::chrono::nanoseconds(kFrameDrain).count() - steady_now_ns();
    if (wait_ns > 0) std::this_thread::sleep_for(std::chrono::nanoseconds(wait_ns));
  }
}

bool WriterBase::delete_writer() noexcept {
  wait_for_frame_drain();
  // Stop callbacks before the listener can go, then delete the writer.
  writer_->set_listener(nullptr);
  if (participant_->publisher->delete_datawriter(writer_) != ReturnCode_t::RETCODE_OK) return false;
  writer_ = nullptr;
  return true;
}

void WriterBase::destroy() noexcept {
  if (writer_ != nullptr) delete_writer();
}

bool WriterBase::wait_for_readers(std::uint32_t count, std::chrono::milliseconds timeout) {
  return matched_->wait_at_least(count, timeout);
}

void* WriterBase::loan_raw() {
  void* sample = nullptr;
  ReturnCode_t code = writer_->loan_sample(sample);
  if (code == ReturnCode_t::RETCODE_OUT_OF_RESOURCES) {
    // Readers return a frame's slot within kFrameDrain. A pool refused for longer is held by
    // something that will not give it back (Fast DDS 2.9 has left a writer's pool stuck after a
    // reader joined it mid-stream, every later frame dropped): a new writer has a fresh pool.
    const std::int64_t now = steady_now_ns();
    if (pool_exhausted_since_ns_ == 0) pool_exhausted_since_ns_ = now;
    const auto stalled = std::chrono::nanoseconds(now - pool_exhausted_since_ns_);
    if (stalled >= kStalledPoolRecovery) {
      recreate();
      std::cerr << "transport: every slot of the '" << topic_ << "' frame pool refused for "
                << std::chrono::duration_cast<std::chrono::milliseconds>(stalled).count()
                << " ms: writer recreated" << std::endl;
      ++pool_recoveries_;
      pool_exhausted_since_ns_ = 0;
      code = writer_->loan_sample(sample);
    }
  }
  if (code != ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("cannot loan a sample on '" + topic_ + "': " + return_code_name(code) +
                             (code == ReturnCode_t::RETCODE_OUT_OF_RESOURCES
                                  ? " (every pool slot is loaned or unread)"
                                  : ""));
  }
  pool_exhausted_since_ns_ = 0;
  return sample;
}

void WriterBase::discard_raw(void* sample) noexcept { writer_->discard_loan(sample); }

bool WriterBase::wait_for_acknowledgments(std::chrono::milliseconds timeout) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(timeout).count();
  const eprosima::fastrtps::Duration_t max_wait(static_cast<std::int32_t>(ns / 1'000'000'000),
                                                static_cast<std::uint32_t>(ns % 1'000'000'000));
  return writer_->wait_for_acknowledgments(max_wait) == ReturnCode_t::RETCODE_OK;
}

void WriterBase::write_raw(void* sample) {
  // The two-argument overload returns a ReturnCode_t; write(void*) returns a bool, which would
  // convert to RETCODE_ERROR (1) on success.
  const ReturnCode_t code =
      writer_->write(sample, eprosima::fastrtps::rtps::c_InstanceHandle_Unknown);
  if (code != ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("cannot write on '" + topic_ + "': " + return_code_name(code));
  }
  ++counters_->samples;
  if (qos_.kind == TopicKind::frame) last_frame_write_ns.store(steady_now_ns());
}

// ---------------------------------------------------------------------------------------------
// Reader

ReaderBase::ReaderBase(Participant& participant, const std::string& topic,
                       const dds::TypeSupport& type, const TopicQos& qos)
    : EndpointBase(participant, topic, type, qos) {
  dds::Topic* dds_topic = participant_->topic(topic, type);
  const dds::StatusMask mask = dds::StatusMask::subscription_matched()
                               << dds::StatusMask::requested_deadline_missed();
  dds::DataReaderQos dds_qos = reader_qos(qos);
  if (qos.kind == TopicKind::packed_frame && !participant_->packed_multicast_group.empty()) {
    // The readers of one packed topic on a host share a multicast locator: its writer sends
    // each sample once for all of them (Fast DDS picks a locator that several readers share)
    // instead of once per reading process. The group's last byte and the port come from the
    // topic and the domain (the RTPS user multicast port, 7401 + 250 x domain).
    eprosima::fastrtps::rtps::Locator_t group;
    group.kind = LOCATOR_KIND_UDPv4;
    std::uint32_t h = 2166136261u;
    for (const char c : topic) h = (h ^ static_cast<std::uint8_t>(c)) * 16777619u;
    std::string address = participant_->packed_multicast_group;
    address = address.substr(0, address.rfind('.') + 1) + std::to_string(1 + h % 250);
    if (!eprosima::fastrtps::rtps::IPLocator::setIPv4(group, address)) {
      throw std::runtime_error("packed frame topic '" + topic + "': bad multicast group " +
                               address + " (thermovis.packed.multicast_group)");
    }
    group.port = 7401 + 250 * static_cast<std::uint32_t>(participant_->domain_id);
    dds_qos.endpoint().multicast_locator_list.push_back(group);
  }
  reader_ = participant_->subscriber->create_datareader(dds_topic, dds_qos, listener_.get(), mask);
  if (reader_ == nullptr) {
    throw std::runtime_error("cannot create DDS reader on '" + topic + "' (see the Fast DDS log)");
  }
}

ReaderBase::~ReaderBase() {
  reader_->set_listener(nullptr);
  participant_->subscriber->delete_datareader(reader_);
}

bool ReaderBase::wait_for_writers(std::uint32_t count, std::chrono::milliseconds timeout) {
  return matched_->wait_at_least(count, timeout);
}

bool ReaderBase::wait_for_data(std::chrono::nanoseconds timeout) {
  const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(timeout);
  return reader_->wait_for_unread_message(
      eprosima::fastrtps::Duration_t(static_cast<std::int32_t>(seconds.count()),
                                     static_cast<std::uint32_t>((timeout - seconds).count())));
}

std::size_t ReaderBase::take_raw(dds::LoanableCollection& data, dds::SampleInfoSeq& infos,
                                 std::int32_t max_samples, std::uint64_t& loan_ticket) {
  detail::release_deferred_unmaps();
  // The ticket comes before the take: a pool unmapped from here on waits for this loan.
  loan_ticket = detail::loan_taken();
  const ReturnCode_t code =
      reader_->take(data, infos, max_samples < 0 ? dds::LENGTH_UNLIMITED : max_samples);
  if (code != ReturnCode_t::RETCODE_OK || data.has_ownership()) {
    detail::loan_returned(std::exchange(loan_ticket, 0));  // nothing loaned
  }
  if (code == ReturnCode_t::RETCODE_NO_DATA) return 0;
  if (code != ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("cannot take from '" + topic_ + "': " + return_code_name(code));
  }
  std::size_t valid = 0;
  for (dds::LoanableCollection::size_type i = 0; i < infos.length(); ++i) {
    if (infos[i].valid_data) ++valid;
  }
  counters_->samples += valid;
  return valid;
}

void ReaderBase::return_raw(dds::LoanableCollection& data, dds::SampleInfoSeq& infos,
                            std::uint64_t loan_ticket) noexcept {
  if (!data.has_ownership()) reader_->return_loan(data, infos);  // else nothing was loaned
  if (loan_ticket != 0) detail::loan_returned(loan_ticket);
}

bool ReaderBase::still_valid_raw(const void* sample, const dds::SampleInfo& info) {
  return reader_->is_sample_valid(sample, &info);
}

}  // namespace thermovis::transport
