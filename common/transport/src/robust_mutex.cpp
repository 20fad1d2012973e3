// Process-shared mutexes that survive the death of their holder.
//
// Fast DDS keeps the notification of each data-sharing reader (a boost.interprocess mutex and
// condition) in a shared-memory segment the reader creates; every writer feeding that reader
// locks the mutex to signal new data, and the reader locks it around its wait. A process killed
// while holding it (SIGKILL of a viewer, a bridge, any service, at the wrong microsecond) leaves
// it locked for good: with Fast DDS's build of boost every later lock times out after 1 s and
// throws "Interprocess mutex timeout when locking. Possible deadlock: owner died without
// unlocking?", out of DataWriter::write() or from a Fast DDS thread where nothing catches it
// (std::terminate), until the dead reader is unmatched at the end of its lease.
//
// This process therefore makes every process-shared mutex it initialises robust (it
// interposes pthread_mutexattr_setpshared, which boost calls for each one), and a lock that
// finds the holder dead (EOWNERDEAD) marks the mutex consistent and succeeds: the notification
// it protects is a flag and a list of waiters that the next notification puts right. Only the
// timed and try locks are interposed: boost, built with a locking timeout as Fast DDS builds
// it, locks interprocess mutexes only through them. Mutexes that are not robust never return
// EOWNERDEAD, so nothing changes for them.
#include <dlfcn.h>
#include <pthread.h>

#include <atomic>
#include <cerrno>
#include <cstdint>

#include "thermovis/transport/shared_memory.hpp"

namespace {

std::atomic<std::uint64_t> made_robust{0};
std::atomic<std::uint64_t> recovered{0};

template <class Function>
Function next_definition(const char* name) {
  return reinterpret_cast<Function>(dlsym(RTLD_NEXT, name));
}

int recover_if_owner_died(pthread_mutex_t* mutex, int result) {
  if (result != EOWNERDEAD) return result;
  pthread_mutex_consistent(mutex);
  recovered.fetch_add(1, std::memory_order_relaxed);
  return 0;
}

}  // namespace

extern "C" int pthread_mutexattr_setpshared(pthread_mutexattr_t* attr, int pshared) noexcept {
  using Function = int (*)(pthread_mutexattr_t*, int);
  static const Function next = next_definition<Function>("pthread_mutexattr_setpshared");
  const int result = next(attr, pshared);
  if (result == 0 && pshared == PTHREAD_PROCESS_SHARED &&
      pthread_mutexattr_setrobust(attr, PTHREAD_MUTEX_ROBUST) == 0)
    made_robust.fetch_add(1, std::memory_order_relaxed);
  return result;
}

extern "C" int pthread_mutex_timedlock(pthread_mutex_t* mutex, const timespec* until) noexcept {
  using Function = int (*)(pthread_mutex_t*, const timespec*);
  static const Function next = next_definition<Function>("pthread_mutex_timedlock");
  return recover_if_owner_died(mutex, next(mutex, until));
}

extern "C" int pthread_mutex_trylock(pthread_mutex_t* mutex) noexcept {
  using Function = int (*)(pthread_mutex_t*);
  static const Function next = next_definition<Function>("pthread_mutex_trylock");
  return recover_if_owner_died(mutex, next(mutex));
}

namespace thermovis::transport {

RobustMutexes robust_mutexes() {
  return {made_robust.load(std::memory_order_relaxed), recovered.load(std::memory_order_relaxed)};
}

}  // namespace thermovis::transport
