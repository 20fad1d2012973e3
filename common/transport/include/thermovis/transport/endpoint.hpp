#pragma once
// Untyped halves of the typed Writer<T> and Reader<T> (writer.hpp, reader.hpp): entity
// creation with the QoS of qos.hpp, matched-status waits, and the per-topic counters fed by the
// DEADLINE and matching listener callbacks.
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>

#include <fastdds/dds/core/LoanableCollection.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "thermovis/transport/counters.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"

namespace thermovis::transport {

// Matched-count bookkeeping shared by writers and readers: the listener stores the count and
// wakes waiters.
class MatchedCount {
 public:
  void set(std::uint32_t count, TopicCounters& counters);
  // True once at least `count` endpoints are matched, false on timeout.
  bool wait_at_least(std::uint32_t count, std::chrono::milliseconds timeout);

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::uint32_t count_ = 0;
};

// How long a frame writer with readers outlives this process's last frame when it is deleted:
// longer than any reader holds a frame (a capture is processed in 20-60 ms, up to ~300 ms on a
// saturated machine). See ~WriterBase.
inline constexpr std::chrono::milliseconds kFrameDrain{500};

// How long a frame writer's pool may stay exhausted (every loan refused) before the writer is
// recreated: longer than any reader legitimately keeps the pool's slots (kFrameDrain), short
// enough that a pool some reader left stuck costs the pipeline about a second, not the rest of
// the run. See WriterBase::loan_raw.
inline constexpr std::chrono::milliseconds kStalledPoolRecovery{1000};

// What writers and readers share: the topic and its QoS, the participant that keeps the DDS
// entities alive, the counters their listener feeds and the matched count.
class EndpointBase {
 public:
  EndpointBase(const EndpointBase&) = delete;
  EndpointBase& operator=(const EndpointBase&) = delete;

  TopicCountersSnapshot counters() const { return counters_->snapshot(topic_); }
  const std::string& topic_name() const { return topic_; }
  const TopicQos& qos() const { return qos_; }

 protected:
  // Throws std::invalid_argument for a frame topic whose type is not plain (data-sharing
  // delivers plain types only).
  EndpointBase(Participant& participant, const std::string& topic,
               const eprosima::fastdds::dds::TypeSupport& type, const TopicQos& qos);
  ~EndpointBase();

  std::shared_ptr<Participant::State> participant_;
  std::string topic_;
  TopicQos qos_;
  std::shared_ptr<TopicCounters> counters_;
  std::shared_ptr<MatchedCount> matched_;
  // Attached to the DDS writer or reader; outlives it (the derived class deletes that first).
  class Listener;
  std::unique_ptr<Listener> listener_;
};

class WriterBase : public EndpointBase {
 public:
  WriterBase(Participant& participant, const std::string& topic,
             const eprosima::fastdds::dds::TypeSupport& type, const TopicQos& qos);
  virtual ~WriterBase();

  // Waits until `count` readers are matched (discovery done). False on timeout.
  bool wait_for_readers(std::uint32_t count, std::chrono::milliseconds timeout);
  // Waits until every matched reliable reader has acknowledged every sample written. False on
  // timeout (or a writer whose readers are best effort only).
  bool wait_for_acknowledgments(std::chrono::milliseconds timeout);
  eprosima::fastdds::dds::DataWriter& native() { return *writer_; }
  // Deletes the DDS writer and creates it anew (a new GUID, a new pool; readers match it again).
  // Throws std::runtime_error when the old writer cannot be deleted (this process still holds
  // loans from it) or the new one cannot be created.
  void recreate();
  // Times loan_raw() recreated the writer because its pool stayed exhausted.
  std::uint64_t pool_recoveries() const { return pool_recoveries_; }

 protected:
  // A sample buffer inside the writer's pool (the data-sharing segment for plain types).
  // Throws when the type is not plain or the pool is exhausted.
  void* loan_raw();
  void discard_raw(void* sample) noexcept;
  // Publishes a loaned buffer (ownership goes back to the writer) or copies a user sample.
  void write_raw(void* sample);

 private:
  eprosima::fastdds::dds::TypeSupport type_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  std::int64_t pool_exhausted_since_ns_ = 0;  // first refused loan of the current run; 0: none
  std::uint64_t pool_recoveries_ = 0;

  void create();
  void destroy() noexcept;
  void wait_for_frame_drain() const;
  // Deletes the DDS writer once its readers had kFrameDrain; false when Fast DDS refuses (loans
  // outstanding): the writer stays, its listener detached.
  bool delete_writer() noexcept;
};

class ReaderBase : public EndpointBase {
 public:
  ReaderBase(Participant& participant, const std::string& topic,
             const eprosima::fastdds::dds::TypeSupport& type, const TopicQos& qos);
  virtual ~ReaderBase();

  // Waits until `count` writers are matched. False on timeout.
  bool wait_for_writers(std::uint32_t count, std::chrono::milliseconds timeout);
  // Waits until an unread sample is available. False on timeout.
  bool wait_for_data(std::chrono::nanoseconds timeout);
  eprosima::fastdds::dds::DataReader& native() { return *reader_; }

 protected:
  // Takes up to max_samples into `data` (loaned from the reader when `data` owns no buffers).
  // Returns the number of samples with valid data; 0 when nothing was available. When samples
  // were loaned, `loan_ticket` keeps the pools they live in mapped until return_raw() (a
  // departed writer's pool stays readable while its samples are held: pool_lifetime.hpp).
  std::size_t take_raw(eprosima::fastdds::dds::LoanableCollection& data,
                       eprosima::fastdds::dds::SampleInfoSeq& infos, std::int32_t max_samples,
                       std::uint64_t& loan_ticket);
  void return_raw(eprosima::fastdds::dds::LoanableCollection& data,
                  eprosima::fastdds::dds::SampleInfoSeq& infos, std::uint64_t loan_ticket) noexcept;
  bool still_valid_raw(const void* sample, const eprosima::fastdds::dds::SampleInfo& info);

 private:
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
};

}  // namespace thermovis::transport
