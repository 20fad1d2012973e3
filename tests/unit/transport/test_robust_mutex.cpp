// Process-shared mutexes survive a holder killed while it holds them: the next lock takes the
// mutex over instead of timing out, and Fast DDS's data-sharing notifications get such mutexes.
#include <gtest/gtest.h>
#include <pthread.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <ctime>

#include "thermovis/test/data.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/shared_memory.hpp"
#include "thermovis/transport/topic_types.hpp"

namespace {

namespace tt = thermovis::transport;

timespec in_seconds(int seconds) {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);
  t.tv_sec += seconds;
  return t;
}

TEST(RobustMutex, ALockHeldByAKilledProcessIsTakenOver) {
  // A mutex in shared memory, initialised the way boost.interprocess does it.
  void* memory = ::mmap(nullptr, sizeof(pthread_mutex_t), PROT_READ | PROT_WRITE,
                        MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(memory, MAP_FAILED);
  auto* mutex = static_cast<pthread_mutex_t*>(memory);
  pthread_mutexattr_t attr;
  pthread_mutexattr_init(&attr);
  const auto before = tt::robust_mutexes();
  ASSERT_EQ(pthread_mutexattr_setpshared(&attr, PTHREAD_PROCESS_SHARED), 0);
  EXPECT_EQ(tt::robust_mutexes().made_robust, before.made_robust + 1);
  int robust = PTHREAD_MUTEX_STALLED;
  pthread_mutexattr_getrobust(&attr, &robust);
  EXPECT_EQ(robust, PTHREAD_MUTEX_ROBUST);
  ASSERT_EQ(pthread_mutex_init(mutex, &attr), 0);
  pthread_mutexattr_destroy(&attr);

  // A process takes the lock and is killed holding it.
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const timespec until = in_seconds(5);
    const char taken = pthread_mutex_timedlock(mutex, &until) == 0 ? 'y' : 'n';
    if (::write(ready[1], &taken, 1) != 1) ::_exit(2);
    ::pause();
    ::_exit(0);
  }
  char taken = 0;
  ASSERT_EQ(::read(ready[0], &taken, 1), 1);
  ASSERT_EQ(taken, 'y');
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);

  // The timed lock boost uses succeeds at once instead of timing out, and so do later ones.
  const timespec until = in_seconds(2);
  EXPECT_EQ(pthread_mutex_timedlock(mutex, &until), 0);
  EXPECT_EQ(tt::robust_mutexes().recovered, before.recovered + 1);
  EXPECT_EQ(pthread_mutex_unlock(mutex), 0);
  EXPECT_EQ(pthread_mutex_trylock(mutex), 0);
  EXPECT_EQ(pthread_mutex_unlock(mutex), 0);
  EXPECT_EQ(tt::robust_mutexes().recovered, before.recovered + 1);
  pthread_mutex_destroy(mutex);
  ::munmap(memory, sizeof(pthread_mutex_t));
  ::close(ready[0]);
  ::close(ready[1]);
}

TEST(RobustMutex, DataSharingReadersGetRobustNotificationMutexes) {
  tt::ParticipantConfig config;
  config.domain_id = thermovis::test::private_domain();
  config.profile = tt::kLoopbackProfile;
  config.profiles_file = tt::shipped_profile_file(config.profile);
  config.name = "robust-mutex-test";
  tt::Participant participant(config);
  const auto before = tt::robust_mutexes().made_robust;
  // A frame reader (data-sharing) creates its notification segment: mutex and condition.
  tt::Reader<thermovis::GridStereoFrame> reader(participant, "thermovis/test/robust-mutex",
                                                tt::frame_topic_qos());
  EXPECT_GT(tt::robust_mutexes().made_robust, before);
}

}  // namespace
