// The frame ring between ioct-gpu and ioct-view: frames arrive whole and in order, a reader that
// falls behind skips to what is still there, a writer that laps a copy is caught, the status
// block reads back, a sleeping reader (another process) is woken by the next frame and by close,
// and a restarted writer or a bad object is recognised.
#include <gtest/gtest.h>

#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <thread>
#include <vector>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/shm/frame_ring.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/shm_object.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"

namespace ioct::shm {
namespace {

using test_support::ScopedShmName;

FrameRingConfig small_config(const std::string& name, std::uint32_t slots = 4) {
  FrameRingConfig c;
  c.name = name;
  c.slots = slots;
  c.max_payload_bytes = 64 * 1024;
  return c;
}

// A payload whose every byte depends on the frame number, so a torn or wrong frame shows.
std::vector<std::byte> pattern(std::uint64_t frame, std::size_t bytes) {
  std::vector<std::byte> v(bytes);
  for (std::size_t i = 0; i < bytes; ++i) v[i] = static_cast<std::byte>((frame * 131 + i) & 0xff);
  return v;
}

FrameMeta meta_for(std::uint64_t group) {
  FrameMeta m{};
  m.group_index = group;
  m.volume_index = group / 8;
  m.t_group_published_ns = 1000 + group;
  m.format = static_cast<std::uint32_t>(FrameFormat::jpeg);
  m.width = 64;
  m.height = 48;
  std::strncpy(m.mode, "enhanced", sizeof m.mode - 1);
  return m;
}

TEST(FrameRing, FramesArriveWholeInOrderWithTheirDescription) {
  ScopedShmName name("frames");
  FrameRingWriter writer(small_config(name.str()));
  FrameRingReader reader = FrameRingReader::attach(name.str());
  Frame frame;
  EXPECT_FALSE(reader.read_next(frame));
  for (std::uint64_t g = 0; g < 3; ++g) {
    const auto render = pattern(g, 1000 + g);
    const auto bscan = pattern(g + 100, 300);
    EXPECT_EQ(writer.publish(meta_for(g), render, bscan), g);
  }
  for (std::uint64_t g = 0; g < 3; ++g) {
    ASSERT_TRUE(reader.read_next(frame)) << "frame " << g;
    EXPECT_EQ(frame.meta.frame_index, g);
    EXPECT_EQ(frame.meta.group_index, g);
    EXPECT_EQ(frame.meta.t_group_published_ns, 1000 + g);
    EXPECT_STREQ(frame.meta.mode, "enhanced");
    EXPECT_GT(frame.meta.t_written_ns, 0u);
    const auto render = pattern(g, 1000 + g);
    const auto bscan = pattern(g + 100, 300);
    ASSERT_EQ(frame.render().size(), render.size());
    ASSERT_EQ(frame.bscan().size(), bscan.size());
    EXPECT_EQ(std::memcmp(frame.render().data(), render.data(), render.size()), 0);
    EXPECT_EQ(std::memcmp(frame.bscan().data(), bscan.data(), bscan.size()), 0);
  }
  EXPECT_FALSE(reader.read_next(frame));
  EXPECT_EQ(reader.frames_skipped(), 0u);
}

// A reader process asleep in wait_for_frame(): what woke it, and how long it slept. The timeout
// is far longer than the test waits, so "woken" and "timed out" cannot be mistaken for each other.
struct Sleeper {
  pid_t pid = -1;
  int result_fd = -1;
};

constexpr std::uint64_t kSleeperTimeoutNs = 60'000'000'000;

Sleeper start_sleeper(const std::string& name) {
  int fds[2];
  EXPECT_EQ(::pipe(fds), 0);
  int ready[2];
  EXPECT_EQ(::pipe(ready), 0);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    ::close(ready[0]);
    FrameRingReader reader = FrameRingReader::attach(name);
    Frame frame;
    while (reader.read_next(frame)) {
    }
    const char go = 'r';
    if (::write(ready[1], &go, 1) != 1) ::_exit(3);
    const std::uint64_t t0 = monotonic_ns();
    const bool woken = reader.wait_for_frame(kSleeperTimeoutNs);
    const std::uint64_t slept[2] = {woken ? 1u : 0u, monotonic_ns() - t0};
    ::_exit(::write(fds[1], slept, sizeof slept) == sizeof slept ? 0 : 4);
  }
  ::close(fds[1]);
  ::close(ready[1]);
  char go = 0;
  EXPECT_EQ(::read(ready[0], &go, 1), 1);
  ::close(ready[0]);
  // Now the child is about to sleep or asleep; a frame from here on must wake it either way.
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return {pid, fds[0]};
}

// {woken, slept_ns} from the sleeper, once it exited.
std::pair<bool, std::uint64_t> sleeper_result(const Sleeper& s) {
  std::uint64_t slept[2] = {0, 0};
  const ssize_t n = ::read(s.result_fd, slept, sizeof slept);
  ::close(s.result_fd);
  int status = 0;
  ::waitpid(s.pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "sleeper status " << status;
  EXPECT_EQ(n, static_cast<ssize_t>(sizeof slept));
  return {slept[0] == 1, slept[1]};
}

TEST(FrameRing, AReaderProcessAsleepIsWokenByTheNextFrame) {
  ScopedShmName name("frames");
  FrameRingWriter writer(small_config(name.str()));
  writer.publish(meta_for(0), pattern(0, 100), pattern(1, 10));
  const Sleeper sleeper = start_sleeper(name.str());
  writer.publish(meta_for(1), pattern(1, 100), pattern(2, 10));
  const auto [woken, slept_ns] = sleeper_result(sleeper);
  EXPECT_TRUE(woken);
  EXPECT_LT(slept_ns, kSleeperTimeoutNs / 2)
      << "slept until the timeout: the frame did not wake it";
}

TEST(FrameRing, AReaderProcessAsleepIsWokenWhenTheWriterCloses) {
  ScopedShmName name("frames");
  FrameRingWriter writer(small_config(name.str()));
  const Sleeper sleeper = start_sleeper(name.str());
  writer.close();
  const auto [woken, slept_ns] = sleeper_result(sleeper);
  EXPECT_TRUE(woken) << "a closed ring is news to the reader";
  EXPECT_LT(slept_ns, kSleeperTimeoutNs / 2) << "slept until the timeout: close did not wake it";
}

TEST(FrameRing, WaitingReturnsAtOnceForAnUnreadFrameAndFalseAfterTheTimeout) {
  ScopedShmName name("frames");
  FrameRingWriter writer(small_config(name.str()));
  FrameRingReader reader = FrameRingReader::attach(name.str());
  EXPECT_FALSE(reader.wait_for_frame(20'000'000)) << "nothing published: the wait times out";
  writer.publish(meta_for(0), pattern(0, 100), pattern(1, 10));
  const std::uint64_t t0 = monotonic_ns();
  EXPECT_TRUE(reader.wait_for_frame(kSleeperTimeoutNs));
  EXPECT_LT(monotonic_ns() - t0, kSleeperTimeoutNs / 2);
  Frame frame;
  ASSERT_TRUE(reader.read_next(frame));
  EXPECT_FALSE(reader.wait_for_frame(1'000'000)) << "the one frame was read";
}

TEST(FrameRing, AReaderARingBehindSkipsToTheOldestFrameStillThere) {
  ScopedShmName name("frames");
  FrameRingWriter writer(small_config(name.str(), 4));
  FrameRingReader reader = FrameRingReader::attach(name.str());
  for (std::uint64_t g = 0; g < 10; ++g) writer.publish(meta_for(g), pattern(g, 64), {});
  Frame frame;
  std::vector<std::uint64_t> seen;
  while (reader.read_next(frame)) seen.push_back(frame.meta.group_index);
  EXPECT_EQ(seen, (std::vector<std::uint64_t>{6, 7, 8, 9}));
  EXPECT_EQ(reader.frames_skipped(), 6u);
}

TEST(FrameRing, AFrameLargerThanASlotIsRefusedAndNothingIsPublished) {
  ScopedShmName name("frames");
  FrameRingWriter writer(small_config(name.str()));
  FrameRingReader reader = FrameRingReader::attach(name.str());
  const std::vector<std::byte> huge(64 * 1024 + 1);
  EXPECT_THROW(writer.publish(meta_for(0), huge, {}), std::length_error);
  Frame frame;
  EXPECT_FALSE(reader.read_next(frame));
  EXPECT_EQ(reader.health().published, 0u);
}

TEST(FrameRing, StatusAndHeartbeatReadBack) {
  ScopedShmName name("frames");
  FrameRingWriter writer(small_config(name.str()));
  FrameRingReader reader = FrameRingReader::attach(name.str());
  FrameRingStatus status{};
  status.source_state = static_cast<std::uint64_t>(SourceState::live);
  status.groups_consumed = 41;
  status.groups_dropped = 2;
  status.last_group_published_ns = 12345;
  status.group_period_ns = 86'000'000;
  writer.set_status(status);
  FrameRingStatus read{};
  ASSERT_TRUE(reader.read_status(read));
  EXPECT_EQ(read.source_state, static_cast<std::uint64_t>(SourceState::live));
  EXPECT_EQ(read.groups_consumed, 41u);
  EXPECT_EQ(read.groups_dropped, 2u);
  EXPECT_EQ(read.last_group_published_ns, 12345u);
  EXPECT_EQ(read.group_period_ns, 86'000'000u);

  // The stage times and device memory travel with the rest of the status.
  status.filter.record(3'000'000);                        // 3 ms: the 5 ms bucket
  status.filter.record(30'000'000);                       // 30 ms: the 50 ms bucket
  status.publish.record(kStageBucketUpperNs.back() + 1);  // past the last edge: the overflow
  status.device_memory_known = 1;
  status.device_memory_used_bytes = 1ull << 30;
  status.device_memory_total_bytes = 80ull << 30;
  writer.set_status(status);
  ASSERT_TRUE(reader.read_status(read));
  EXPECT_EQ(read.filter.count, 2u);
  EXPECT_EQ(read.filter.sum_ns, 33'000'000u);
  EXPECT_EQ(kStageBucketUpperNs[5], 5'000'000u);
  EXPECT_EQ(read.filter.counts[5], 1u);
  EXPECT_EQ(kStageBucketUpperNs[8], 50'000'000u);
  EXPECT_EQ(read.filter.counts[8], 1u);
  EXPECT_EQ(read.publish.counts[kStageBuckets - 1], 1u);
  EXPECT_EQ(read.render.count, 0u);
  EXPECT_EQ(read.device_memory_known, 1u);
  EXPECT_EQ(read.device_memory_total_bytes, 80ull << 30);

  writer.heartbeat(monotonic_ns());
  FrameWriterHealth health = reader.health();
  EXPECT_TRUE(health.alive);
  EXPECT_LT(health.heartbeat_age_ns, 1'000'000'000u);
  writer.close();
  EXPECT_FALSE(reader.health().alive) << "a closed ring must not look alive";
  EXPECT_FALSE(ShmObject::exists(name.str()));
}

TEST(FrameRing, ARestartedWriterIsANewObjectWithANewEpoch) {
  ScopedShmName name("frames");
  std::uint64_t first_epoch = 0;
  {
    FrameRingWriter writer(small_config(name.str()));
    first_epoch = writer.epoch();
    writer.publish(meta_for(0), pattern(0, 10), {});
  }
  FrameRingWriter again(small_config(name.str()));
  EXPECT_NE(again.epoch(), first_epoch);
  FrameRingReader reader = FrameRingReader::attach(name.str());
  Frame frame;
  EXPECT_FALSE(reader.read_next(frame)) << "the new writer has published nothing yet";
}

TEST(FrameRing, ASecondWriterWhileTheFirstLivesIsRefused) {
  ScopedShmName name("frames");
  FrameRingWriter writer(small_config(name.str()));
  try {
    FrameRingWriter second(small_config(name.str()));
    FAIL() << "a second writer was allowed";
  } catch (const RingError& e) {
    EXPECT_EQ(e.code(), RingErrc::owned_by_live_producer);
  }
}

TEST(FrameRing, AForeignObjectIsLeftAloneAndNotAttached) {
  ScopedShmName name("frames");
  {
    ShmObject foreign = ShmObject::create(name.str(), 8192, 0600, "");
    std::memset(foreign.data(), 0x5a, 64);
  }
  try {
    FrameRingWriter writer(small_config(name.str()));
    FAIL() << "a foreign object was taken over";
  } catch (const RingError& e) {
    EXPECT_EQ(e.code(), RingErrc::foreign);
  }
  try {
    (void)FrameRingReader::attach(name.str());
    FAIL() << "a foreign object was attached";
  } catch (const RingError& e) {
    EXPECT_EQ(e.code(), RingErrc::foreign);
  }
  EXPECT_TRUE(ShmObject::exists(name.str()));
}

TEST(FrameRing, HeaderValidationNamesTheField) {
  FrameRingHeader h{};
  h.magic = kFrameRingMagic;
  h.layout_version = kFrameRingVersion;
  h.header_bytes = 4096;
  h.slot_count = 4;
  h.max_payload_bytes = 65536;
  h.slot_stride = 4096 + 65536;
  const std::uint64_t bytes = 4096 + 4 * h.slot_stride;
  EXPECT_NO_THROW(validate_frame_ring_header(h, bytes, "f"));
  const auto message_of = [&](FrameRingHeader bad, std::uint64_t size) -> std::string {
    try {
      validate_frame_ring_header(bad, size, "f");
    } catch (const RingError& e) {
      return e.what();
    }
    return "accepted";
  };
  FrameRingHeader bad = h;
  bad.slot_count = 1'000'000;
  EXPECT_NE(message_of(bad, bytes).find("slot_count"), std::string::npos);
  bad = h;
  bad.slot_stride = 12;
  EXPECT_NE(message_of(bad, bytes).find("slot_stride"), std::string::npos);
  bad = h;
  bad.max_payload_bytes = ~0ull;
  EXPECT_NE(message_of(bad, bytes).find("max_payload_bytes"), std::string::npos);
  EXPECT_NE(message_of(h, bytes - 1).find("needs"), std::string::npos);
  bad = h;
  bad.layout_version = 99;
  EXPECT_NE(message_of(bad, bytes).find("layout version 99"), std::string::npos);
  // A reader of this layout never maps a ring of the previous one (its status is shorter).
  bad = h;
  bad.layout_version = kFrameRingVersion - 1;
  EXPECT_NE(message_of(bad, bytes)
                .find("layout version " + std::to_string(kFrameRingVersion - 1) + ", expected " +
                      std::to_string(kFrameRingVersion)),
            std::string::npos);
}

TEST(FrameRing, ConfigErrorsNameTheKey) {
  const auto message_of = [](FrameRingConfig c) -> std::string {
    try {
      c.validate();
    } catch (const RingError& e) {
      return e.what();
    }
    return "accepted";
  };
  FrameRingConfig c = small_config("x");
  c.slots = 1;
  EXPECT_NE(message_of(c).find("frames.slots = 1"), std::string::npos);
  c = small_config("a/b");
  EXPECT_NE(message_of(c).find("frames.name"), std::string::npos);
  c = small_config("x");
  c.max_payload_bytes = kMaxFramePayloadBytes + 1;
  EXPECT_NE(message_of(c).find("frames.max_payload_bytes"), std::string::npos);
}

// A writer publishing as fast as it can against a reader copying: every frame the reader accepts
// is intact (its payload matches its frame number), and every frame is either read or skipped.
TEST(FrameRing, ConcurrentReaderNeverAcceptsATornFrame) {
  ScopedShmName name("frames");
  FrameRingWriter writer(small_config(name.str(), 3));
  FrameRingReader reader = FrameRingReader::attach(name.str());
  constexpr std::uint64_t kFrames = 3000;
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (std::uint64_t g = 0; g < kFrames; ++g) {
      writer.publish(meta_for(g), pattern(g, 4096 + (g % 7) * 1000), {});
    }
    done.store(true, std::memory_order_release);
  });
  Frame frame;
  std::uint64_t read = 0;
  std::uint64_t torn = 0;
  std::uint64_t last = 0;
  bool any = false;
  for (;;) {
    const bool finished = done.load(std::memory_order_acquire);
    while (reader.read_next(frame)) {
      const std::uint64_t g = frame.meta.group_index;
      const auto expected = pattern(g, 4096 + (g % 7) * 1000);
      if (frame.payload.size() != expected.size() ||
          std::memcmp(frame.payload.data(), expected.data(), expected.size()) != 0) {
        ++torn;
      }
      if (any) {
        EXPECT_GT(g, last) << "frames must come in order";
      }
      last = g;
      any = true;
      ++read;
    }
    if (finished) break;
  }
  producer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_GT(read, 0u);
  EXPECT_EQ(read + reader.frames_skipped(), kFrames);
}

}  // namespace
}  // namespace ioct::shm
