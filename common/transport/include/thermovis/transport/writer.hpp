#pragma once
// Typed DDS writer. For plain frame types, loan() hands out a buffer inside the writer's
// data-sharing pool; filling it and publish() delivers the frame to readers on this host with
// no copy at all. write() copies a sample the caller owns (small types, or a frame kept
// elsewhere: one memcpy into the pool).
#include <utility>

#include "thermovis/transport/bounds.hpp"
#include "thermovis/transport/endpoint.hpp"
#include "thermovis/transport/topic_types.hpp"

namespace thermovis::transport {

template <class T>
class Writer;

// A sample loaned from a writer's pool. Publish it with Writer::publish; a loan destroyed
// unpublished goes back to the pool. Its contents are NOT initialised: set every field.
template <class T>
class Loan {
 public:
  Loan(Loan&& other) noexcept
      : writer_(std::exchange(other.writer_, nullptr)),
        sample_(std::exchange(other.sample_, nullptr)) {}
  Loan& operator=(Loan&&) = delete;
  Loan(const Loan&) = delete;
  ~Loan() {
    if (sample_ != nullptr) writer_->discard(sample_);
  }
  T& operator*() const { return *sample_; }
  T* operator->() const { return sample_; }
  T* get() const { return sample_; }

 private:
  friend class Writer<T>;
  Loan(Writer<T>* writer, T* sample) : writer_(writer), sample_(sample) {}
  Writer<T>* writer_;
  T* sample_;
};

template <class T>
class Writer : public WriterBase {
 public:
  Writer(Participant& participant, const std::string& topic, const TopicQos& qos)
      : WriterBase(participant, topic, make_type_support<T>(), qos) {}

  // Throws std::runtime_error when T is not plain or every pool slot is in use.
  Loan<T> loan() { return Loan<T>(this, static_cast<T*>(loan_raw())); }

  // Publishes a loaned sample. On failure the buffer goes back to the pool and the error is
  // thrown; either way the loan is consumed.
  void publish(Loan<T>&& loan) {
    T* sample = std::exchange(loan.sample_, nullptr);
    try {
      write_raw(sample);
    } catch (...) {
      discard_raw(sample);
      throw;
    }
  }

  // Copies `sample` into the writer. Throws std::invalid_argument when a sequence exceeds its
  // IDL bound (bounds.hpp).
  void write(const T& sample) {
    if constexpr (HasBounds<T>) check_bounds(sample);
    write_raw(const_cast<T*>(&sample));  // Fast DDS takes void* but only reads it
  }

 private:
  friend class Loan<T>;
  void discard(T* sample) noexcept { discard_raw(sample); }
};

}  // namespace thermovis::transport
