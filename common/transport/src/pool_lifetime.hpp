#pragma once
// Keeps a departed writer's data-sharing pool mapped while this process may still read it.
//
// Fast DDS 2.9 maps each matched writer's pool read-only into a data-sharing reader and unmaps
// it as soon as the writer is unmatched (deleted, or its participant gone): loaned samples of
// that writer, and samples still waiting in the reader's history (whose validity take() checks
// in the pool), then point into unmapped memory, and the reader crashes. A writer stopping
// cleanly while its reader works on one of its frames is enough.
//
// This process therefore provides munmap() (it interposes the C library's for the shared
// libraries, Fast DDS among them): the unmapping of a read-only /dev/shm/fast_datasharing_*
// segment is deferred until every loan taken before it has been returned and a grace period
// (for samples still in a history) has passed; any other munmap goes straight to the kernel.
#include <cstdint>

namespace thermovis::transport::detail {

// A take() that loaned samples: the ticket to return with loan_returned().
std::uint64_t loan_taken();
void loan_returned(std::uint64_t ticket) noexcept;

// Unmaps the deferred pools nothing can read any more (called on every take and return).
void release_deferred_unmaps() noexcept;

struct DeferredUnmaps {
  std::size_t pending = 0;     // pools kept mapped for now
  std::uint64_t deferred = 0;  // unmappings deferred since start
  std::uint64_t released = 0;  // of which done since
};
DeferredUnmaps deferred_unmaps();

}  // namespace thermovis::transport::detail
