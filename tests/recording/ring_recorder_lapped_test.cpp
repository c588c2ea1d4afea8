// The recorder lapped by the ring's writer, in-process on a real shared-memory ring: a ring of
// two 1 MiB slots and a writer that publishes a group in well under a microsecond (it stamps a
// few words of each group, not all of it), so that the slot the recorder is copying is
// overwritten under it, before and during the copy (end_read() refuses the copy), and even
// between the cursor and the slot on every try of a poll (begin_read() returns lapped). The
// recorder must count those groups as lapped (in its counters, its file, record-status and its
// status line), write none of them, lose none uncounted, and record on once the writer slows
// down.
//
// Each group's payload is zero but for words that name the group (its first, middle and last
// words), and its slot header carries values derived from its index: a copy that mixes two
// groups, or a group written under another's header, does not match what was published.
#include <pthread.h>
#include <sched.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <span>
#include <streambuf>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include "ioct/common/log.hpp"
#include "ioct/ringrec/recorder_control.hpp"
#include "ioct/ringrec/ring_recorder.hpp"
#include "ioct/ringrec/ring_recording_format.hpp"
#include "ioct/ringrec/ring_recording_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/test_support/eventually.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "ioct/test_support/temp_path.hpp"

namespace ioct::ringrec {
namespace {

using namespace std::chrono_literals;

constexpr std::uint64_t kSlots = 2;               // the fewest a ring may have
constexpr std::size_t kStampStride = 512 * 1024;  // bytes between a payload's stamped words
constexpr std::uint64_t kPacedGroups = 8;         // published one at a time, before and after
// Generous: only a recorder that never catches up waits this long (a sanitizer's build on a
// busy two-core machine is slow, not stuck).
constexpr auto kCatchUpTimeout = 20s;

// 1024 samples x 128 A-scans x 4 B-scans x 2 bytes: 1 MiB, a copy long enough for a writer that
// publishes in a fraction of a microsecond to lap it.
shm::RingGeometry lapped_geometry() {
  shm::RingGeometry g;
  g.samples_per_ascan = 1024;
  g.ascans_per_bscan = 128;
  g.bscans_per_group = 4;
  g.bscans_per_volume = 8;
  g.bytes_per_sample = 2;
  return g;
}

std::uint64_t stamp(std::uint64_t group, std::size_t word) {
  return ((group + 1) * 0x9E3779B97F4A7C15ull) ^ word;
}

bool stamped(std::size_t word, std::size_t words) {
  return word * sizeof(std::uint64_t) % kStampStride == 0 || word + 1 == words;
}

// Writes group `group`'s stamps; the rest of each slot stays zero from the ring's creation.
void write_stamps(std::span<std::byte> payload, std::uint64_t group) {
  const std::size_t words = payload.size() / sizeof(std::uint64_t);
  for (std::size_t w = 0; w < words; w += kStampStride / sizeof(std::uint64_t)) {
    const std::uint64_t value = stamp(group, w);
    std::memcpy(payload.data() + w * sizeof value, &value, sizeof value);
  }
  const std::uint64_t last = stamp(group, words - 1);
  std::memcpy(payload.data() + (words - 1) * sizeof last, &last, sizeof last);
}

// Empty when `payload` is exactly group `group`'s, else the first word that is not.
std::string payload_mismatch(std::span<const std::byte> payload, std::uint64_t group) {
  const std::size_t words = payload.size() / sizeof(std::uint64_t);
  for (std::size_t w = 0; w < words; ++w) {
    std::uint64_t value = 0;
    std::memcpy(&value, payload.data() + w * sizeof value, sizeof value);
    const std::uint64_t expected = stamped(w, words) ? stamp(group, w) : 0;
    if (value != expected) {
      return "payload word " + std::to_string(w) + " is " + std::to_string(value) + ", group " +
             std::to_string(group) + " has " + std::to_string(expected);
    }
  }
  return {};
}

void stamp_header(shm::SlotHeader& h, std::uint64_t group, const shm::RingGeometry& g) {
  h.first_sweep_counter = 1000 * group + 7;
  h.t_first_sweep_ns = 3 * group;
  h.t_last_sweep_ns = 3 * group + 1;
  h.bscan_count = g.bscans_per_group;
  for (std::uint32_t b = 0; b < g.bscans_per_group; ++b) {
    h.bscans[b].volume_index = group;
    h.bscans[b].bscan_in_volume = b;
  }
}

// Empty when `h` is group `group`'s header as published in `epoch`, else what differs.
std::string header_mismatch(const shm::SlotHeader& h, std::uint64_t group, std::uint64_t epoch,
                            const shm::RingGeometry& g) {
  if (h.group_index != group) return "group_index " + std::to_string(h.group_index);
  if (h.producer_epoch != epoch) return "producer_epoch " + std::to_string(h.producer_epoch);
  if (h.payload_bytes != g.group_payload_bytes()) return "payload_bytes";
  if (h.first_sweep_counter != 1000 * group + 7 || h.t_first_sweep_ns != 3 * group ||
      h.t_last_sweep_ns != 3 * group + 1 || h.bscan_count != g.bscans_per_group) {
    return "a field of another group (first_sweep_counter " +
           std::to_string(h.first_sweep_counter) + ")";
  }
  for (std::uint32_t b = 0; b < g.bscans_per_group; ++b) {
    if (h.bscans[b].volume_index != group || h.bscans[b].bscan_in_volume != b) {
      return "B-scan marker " + std::to_string(b) + " of another group";
    }
  }
  return {};
}

void publish_group(shm::RingWriter& writer) {
  const shm::RingWriter::Claim claim = writer.claim();
  write_stamps(claim.payload, claim.group);
  stamp_header(*claim.header, claim.group, writer.config().geometry);
  writer.publish(claim);
}

std::uint64_t at(const CounterValues& c, Counter which) {
  return c[static_cast<std::size_t>(which)];
}

// Groups the recorder has finished with: in the file, or counted as lost for one cause.
std::uint64_t accounted(const CounterValues& c) {
  return at(c, Counter::groups_written) + at(c, Counter::dropped_lapped) +
         at(c, Counter::dropped_behind) + at(c, Counter::dropped_queue_full) +
         at(c, Counter::dropped_disk_full);
}

std::string describe(const CounterValues& c) {
  std::string out;
  for (std::size_t i = 0; i < kCounterCount; ++i) {
    out += std::string(kCounterNames[i]) + " " + std::to_string(c[i]) +
           (i + 1 < kCounterCount ? ", " : "");
  }
  return out;
}

// What the recorder's log wrote, readable by the test while the recorder writes more.
class SharedText : public std::streambuf {
 public:
  std::string text() const {
    const std::lock_guard lock(mutex_);
    return text_;
  }

 protected:
  int_type overflow(int_type c) override {
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      const std::lock_guard lock(mutex_);
      text_.push_back(traits_type::to_char_type(c));
    }
    return traits_type::not_eof(c);
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    const std::lock_guard lock(mutex_);
    text_.append(s, static_cast<std::size_t>(n));
    return n;
  }

 private:
  mutable std::mutex mutex_;
  std::string text_;
};

// The largest "lapped N" of the recorder's status lines ("... lost: lapped N, behind ...").
std::uint64_t lapped_in_status_lines(const std::string& text) {
  static constexpr std::string_view kKey = "lost: lapped ";
  std::uint64_t largest = 0;
  for (std::size_t pos = text.find(kKey); pos != std::string::npos;
       pos = text.find(kKey, pos + 1)) {
    largest = std::max<std::uint64_t>(largest, std::stoull(text.substr(pos + kKey.size(), 20)));
  }
  return largest;
}

// Two CPUs this process may run on, when it may run on two: the recorder's thread goes on one and
// the writer on the other, so that the writer runs while the recorder copies. Left to itself the
// scheduler may put both on one CPU of a busy two-core machine, where the writer runs only
// between the recorder's copies and laps it seldom (on one CPU, in seconds or never).
std::optional<std::pair<int, int>> two_cpus() {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (::sched_getaffinity(0, sizeof allowed, &allowed) != 0) return std::nullopt;
  std::vector<int> cpus;
  for (int cpu = 0; cpu < CPU_SETSIZE && cpus.size() < 2; ++cpu) {
    if (CPU_ISSET(cpu, &allowed)) cpus.push_back(cpu);
  }
  if (cpus.size() < 2) return std::nullopt;
  return std::pair{cpus[0], cpus[1]};
}

// Runs the calling thread on `cpu` until destroyed, then where it ran before. Does nothing when
// the pinning is refused (the test still runs, only less often lapped).
class PinnedThread {
 public:
  explicit PinnedThread(int cpu) {
    if (::pthread_getaffinity_np(::pthread_self(), sizeof before_, &before_) != 0) return;
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpu, &one);
    pinned_ = ::pthread_setaffinity_np(::pthread_self(), sizeof one, &one) == 0;
  }
  ~PinnedThread() {
    if (pinned_) ::pthread_setaffinity_np(::pthread_self(), sizeof before_, &before_);
  }
  PinnedThread(const PinnedThread&) = delete;
  PinnedThread& operator=(const PinnedThread&) = delete;

 private:
  cpu_set_t before_{};
  bool pinned_ = false;
};

TEST(RingRecorderLapped, LappedGroupsAreCountedNoneWrittenNoneLostAndTheRecordingGoesOn) {
  const std::optional<std::pair<int, int>> cpus = two_cpus();
  if (!cpus) GTEST_SKIP() << "needs two CPUs: a writer on one lapping the recorder on the other";
  const test_support::ScopedShmName ring("rec-lapped");
  const test_support::TempPath out("rec-lapped", ".h5");
  shm::RingConfig ring_config;
  ring_config.name = ring.str();
  ring_config.geometry = lapped_geometry();
  ring_config.slot_count = kSlots;
  shm::RingWriter writer = shm::RingWriter::create(ring_config);
  const shm::RingGeometry& geometry = writer.config().geometry;

  RecorderConfig config;
  config.ring_name = ring.str();
  config.out = out.path();
  config.wait_s = 5;
  config.exit_when_producer_gone = true;  // the writer's close() ends the recording in order
  config.queue_groups = 2;
  config.status_interval_s = 0.05;
  config.poll_interval_s = 1e-4;
  config.label = "lapped-test";
  SharedText log_text;
  std::ostream log_stream(&log_text);
  const Log log("ioct-record", log_stream);
  RingRecorder recorder(config);
  RecorderSummary summary;
  std::exception_ptr failure;
  std::thread recording([&] {
    // Its disk writer thread, started by run(), shares the CPU.
    const PinnedThread pinned(cpus->first);
    try {
      summary = recorder.run(&log);
    } catch (...) {
      failure = std::current_exception();
    }
  });
  struct StopAndJoin {
    RingRecorder& recorder;
    std::thread& thread;
    ~StopAndJoin() {
      if (!thread.joinable()) return;
      recorder.request_stop();
      thread.join();
    }
  } stop_and_join{recorder, recording};

  // Caught up: the recorder is done with every group published, each in the file or counted as
  // lost (the queue drained). A recorder that counts a group twice overshoots, and is caught by
  // the checks that follow rather than by a timeout.
  const auto caught_up = [&] {
    return test_support::eventually(
        [&] { return accounted(recorder.status().counters) >= writer.published(); },
        kCatchUpTimeout);
  };
  const auto counted_once = [&] {
    const CounterValues c = recorder.status().counters;
    EXPECT_EQ(accounted(c), writer.published())
        << "each group published is in the file or counted as lost, once: " << describe(c);
  };
  ASSERT_TRUE(test_support::eventually([&] { return recorder.status().recording; }, 10s))
      << "the recorder did not start recording";

  // Before the lap: one group at a time, each read before the next overwrites anything.
  for (std::uint64_t i = 0; i < kPacedGroups; ++i) {
    publish_group(writer);
    ASSERT_TRUE(caught_up()) << describe(recorder.status().counters);
    counted_once();
  }
  ASSERT_EQ(at(recorder.status().counters, Counter::groups_written), kPacedGroups)
      << describe(recorder.status().counters);

  // The lap: publish as fast as the writer can, until the recorder has counted a lapped group
  // and for at least 100 ms (long enough that it also meets polls that begin_read() gives up on,
  // lapped on every try).
  std::optional<PinnedThread> writer_pinned;
  writer_pinned.emplace(cpus->second);
  const auto burst_start = std::chrono::steady_clock::now();
  const auto give_up = burst_start + 10s;
  std::uint64_t lapped = 0;
  for (;;) {
    for (int i = 0; i < 256; ++i) publish_group(writer);
    const RecorderStatus now_status = recorder.status();
    if (!now_status.recording) {
      FAIL() << "the recording ended while the writer lapped it: "
             << (now_status.last ? now_status.last->stop_reason : "(no summary)");
    }
    lapped = at(now_status.counters, Counter::dropped_lapped);
    const auto now = std::chrono::steady_clock::now();
    if ((lapped > 0 && now - burst_start >= 100ms) || now > give_up) break;
  }
  const std::uint64_t burst_end = writer.published();
  writer_pinned.reset();
  ASSERT_GT(lapped, 0u) << "the recorder was never lapped in 10 s of " << burst_end
                        << " groups published into " << kSlots
                        << " slots: " << describe(recorder.status().counters);
  ASSERT_TRUE(caught_up()) << "published " << writer.published() << ": "
                           << describe(recorder.status().counters);
  counted_once();
  // record-status reports the lapped groups as the recorder counts them.
  const nlohmann::json status =
      nlohmann::json::parse(recorder_control_reply(recorder, R"({"cmd": "record-status"})"));
  const CounterValues after_lap = recorder.status().counters;
  ASSERT_TRUE(status.value("ok", false)) << status.dump();
  EXPECT_TRUE(status["status"]["recording"].get<bool>()) << status.dump();
  EXPECT_EQ(status["status"]["dropped"]["lapped"].get<std::uint64_t>(),
            at(after_lap, Counter::dropped_lapped))
      << status.dump();
  EXPECT_GE(status["status"]["dropped"]["lapped"].get<std::uint64_t>(), 1u) << status.dump();

  // After the lap: the recorder goes on; each group read before the next is published.
  for (std::uint64_t i = 0; i < kPacedGroups; ++i) {
    publish_group(writer);
    ASSERT_TRUE(caught_up()) << "group " << writer.published() - 1
                             << " after the lap: " << describe(recorder.status().counters);
    counted_once();
  }
  // Its status line reports them.
  EXPECT_TRUE(
      test_support::eventually([&] { return lapped_in_status_lines(log_text.text()) >= 1; }, 10s))
      << "no status line counts a lapped group:\n"
      << log_text.text();
  const std::uint64_t published = writer.published();
  writer.close();
  recording.join();
  if (failure) std::rethrow_exception(failure);
  EXPECT_EQ(summary.stop_reason, "producer gone");
  EXPECT_FALSE(summary.failed);

  const RingRecordingReader file(out.path());
  EXPECT_TRUE(file.finished());
  const CounterValues& c = file.counters();
  EXPECT_EQ(c, summary.counters) << "file: " << describe(c)
                                 << "; run(): " << describe(summary.counters);
  EXPECT_EQ(at(c, Counter::groups_written), file.group_count()) << describe(c);
  EXPECT_GE(at(c, Counter::dropped_lapped), lapped) << describe(c);
  EXPECT_EQ(accounted(c), published)
      << "every group published is in the file or counted as lost, once: " << describe(c);
  EXPECT_EQ(at(c, Counter::producer_restarts), 0u) << "a lapped poll is not the producer's end";
  EXPECT_EQ(at(c, Counter::dropped_disk_full), 0u) << describe(c);

  // Every group in the file is the one the writer published, whole, in the order published:
  // the groups before the lap, the lap's survivors, and every group after it.
  std::vector<std::byte> payload(file.group_bytes());
  shm::SlotHeader header{};
  std::vector<std::uint64_t> recorded;
  for (std::uint64_t i = 0; i < file.group_count(); ++i) {
    file.read_group(i, payload, header);
    const std::uint64_t group = header.group_index;
    EXPECT_EQ(header_mismatch(header, group, writer.epoch(), geometry), "")
        << "file group " << i << " (ring group " << group << ")";
    EXPECT_EQ(payload_mismatch(payload, group), "")
        << "file group " << i << " (ring group " << group << ")";
    if (!recorded.empty()) {
      EXPECT_GT(group, recorded.back()) << "file group " << i << " is out of order";
    }
    EXPECT_LT(group, published) << "file group " << i;
    recorded.push_back(group);
  }
  ASSERT_GE(recorded.size(), 2 * kPacedGroups);
  for (std::uint64_t i = 0; i < kPacedGroups; ++i) {
    EXPECT_EQ(recorded[i], i) << "a group published before the lap is missing";
    EXPECT_EQ(recorded[recorded.size() - kPacedGroups + i], burst_end + i)
        << "a group published after the lap is missing";
  }
  std::printf(
      "[ figures  ] %llu groups published (%llu in the burst), %llu recorded, lost: lapped %llu, "
      "behind %llu, queue full %llu\n",
      static_cast<unsigned long long>(published),
      static_cast<unsigned long long>(burst_end - kPacedGroups),
      static_cast<unsigned long long>(recorded.size()),
      static_cast<unsigned long long>(at(c, Counter::dropped_lapped)),
      static_cast<unsigned long long>(at(c, Counter::dropped_behind)),
      static_cast<unsigned long long>(at(c, Counter::dropped_queue_full)));
}

}  // namespace
}  // namespace ioct::ringrec
