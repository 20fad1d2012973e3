#pragma once
// Typed DDS reader. take() returns the samples loaned from the middleware: for plain frame
// types delivered by data-sharing they point straight into the writer's shared-memory pool
// (no copy); the loan goes back when the Samples object is destroyed. The pool stays mapped
// while the samples are held, even when its writer goes away meanwhile (stopped or killed).
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <fastdds/dds/core/LoanableSequence.hpp>

#include "thermovis/transport/endpoint.hpp"
#include "thermovis/transport/topic_types.hpp"

namespace thermovis::transport {

template <class T>
class Reader;

// Samples taken from a reader, valid (and pinned) until destruction. Only samples with
// valid data are visible (disposal notifications are skipped).
template <class T>
class Samples {
 public:
  using Index = eprosima::fastdds::dds::LoanableCollection::size_type;

  Samples(Samples&& other) noexcept
      : reader_(std::exchange(other.reader_, nullptr)),
        data_(std::move(other.data_)),
        infos_(std::move(other.infos_)),
        valid_(std::move(other.valid_)),
        loan_ticket_(std::exchange(other.loan_ticket_, 0)) {}
  Samples& operator=(Samples&&) = delete;
  Samples(const Samples&) = delete;
  ~Samples() {
    if (reader_ != nullptr) reader_->give_back(*data_, *infos_, loan_ticket_);
  }

  std::size_t size() const { return valid_.size(); }
  bool empty() const { return valid_.empty(); }
  const T& operator[](std::size_t i) const { return (*data_)[valid_[i]]; }
  const eprosima::fastdds::dds::SampleInfo& info(std::size_t i) const {
    return (*infos_)[valid_[i]];
  }
  // False when the writer has reused the sample's data-sharing slot since it was taken (the
  // reader held it too long); check after processing a loaned frame.
  bool still_valid(std::size_t i) const { return reader_->still_valid(&(*this)[i], info(i)); }

 private:
  friend class Reader<T>;
  explicit Samples(Reader<T>* reader)
      : reader_(reader),
        data_(std::make_unique<eprosima::fastdds::dds::LoanableSequence<T>>()),
        infos_(std::make_unique<eprosima::fastdds::dds::SampleInfoSeq>()) {}
  Reader<T>* reader_;
  // Heap-held so that moving Samples does not move the sequences the middleware lent.
  std::unique_ptr<eprosima::fastdds::dds::LoanableSequence<T>> data_;
  std::unique_ptr<eprosima::fastdds::dds::SampleInfoSeq> infos_;
  std::vector<Index> valid_;
  std::uint64_t loan_ticket_ = 0;
};

template <class T>
class Reader : public ReaderBase {
 public:
  Reader(Participant& participant, const std::string& topic, const TopicQos& qos)
      : ReaderBase(participant, topic, make_type_support<T>(), qos) {}

  // Takes every available sample (at most max_samples), without waiting.
  Samples<T> take(std::int32_t max_samples = -1) {
    Samples<T> samples(this);
    take_raw(*samples.data_, *samples.infos_, max_samples, samples.loan_ticket_);
    for (typename Samples<T>::Index i = 0; i < samples.infos_->length(); ++i) {
      if ((*samples.infos_)[i].valid_data) samples.valid_.push_back(i);
    }
    return samples;
  }

 private:
  friend class Samples<T>;
  void give_back(eprosima::fastdds::dds::LoanableSequence<T>& data,
                 eprosima::fastdds::dds::SampleInfoSeq& infos, std::uint64_t loan_ticket) noexcept {
    return_raw(data, infos, loan_ticket);
  }
  bool still_valid(const T* sample, const eprosima::fastdds::dds::SampleInfo& info) {
    return still_valid_raw(sample, info);
  }
};

}  // namespace thermovis::transport
