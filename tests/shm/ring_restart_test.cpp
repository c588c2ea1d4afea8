// A producer restart seen by a reader that keeps running:
//  (a) the producer is killed and a new one of the same layout reuses the object in place: the
//      reader sees the epoch change and goes on reading the new producer's groups;
//  (b) the producer closes in order: the reader gets producer_gone, attaches to the new ring;
//  (c) a new producer of another layout: the old object is retired (producer_gone) and replaced.
// And a second producer is refused while the first one lives.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "attach_when_ready.hpp"
#include "group_verifier.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/shm/shm_object.hpp"
#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "peer_line.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using test_support::ChildProcess;
using test_support::ScopedShmName;

// A producer in a process of its own, publishing a test group every 200 us.
struct WriterPeer {
  ChildProcess process;
  std::uint64_t epoch = 0;
  std::string action;  // StartupAction: created, reused_stale, replaced_stale
};

WriterPeer start_writer_peer(const std::string& name, std::vector<std::string> extra = {}) {
  std::vector<std::string> args = {"writer", "--ring", name, "--period-us", "200"};
  args.insert(args.end(), extra.begin(), extra.end());
  WriterPeer peer{ChildProcess::spawn(test_support::sibling_executable("ring_stress_peer"), args),
                  0, ""};
  const auto line = peer.process.read_line(30s);
  if (!line) throw std::runtime_error("the writer peer did not start");
  const auto ready = parse_peer_line(*line);
  if (!ready || ready->kind != "ready") throw std::runtime_error("writer peer: " + *line);
  peer.epoch = ready->number("epoch");
  peer.action = ready->field("action");
  return peer;
}

// Ends a writer peer in order (SIGTERM: it closes the ring) and checks it exited cleanly.
void close_writer_peer(WriterPeer& peer) {
  peer.process.send_signal(SIGTERM);
  const auto line = peer.process.read_line(30s);
  ASSERT_TRUE(line);
  EXPECT_EQ(parse_peer_line(*line)->kind, "closed") << *line;
  const auto status = peer.process.wait_for(30s);
  ASSERT_TRUE(status);
  EXPECT_TRUE(WIFEXITED(*status) && WEXITSTATUS(*status) == 0)
      << test_support::describe_wait_status(*status);
}

void kill_writer_peer(WriterPeer& peer) {
  const int status = peer.process.kill_and_wait();
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
}

// Reads and verifies groups until `count` groups of `epoch` were verified in a row. Returns
// ready when they were, producer_gone when the ring went away first, empty on timeout.
shm::PollStatus consume(shm::RingReader& reader, GroupVerifier& verifier, std::uint64_t count,
                        std::uint64_t epoch, Clock::duration timeout = 30s) {
  std::vector<std::byte> buffer(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    const shm::PollStatus status = reader.read_next(buffer, header);
    if (status == shm::PollStatus::producer_gone) return status;
    if (status == shm::PollStatus::ready) {
      verifier.check(header, buffer, reader.position() - 1, reader.epoch());
      if (verifier.last_epoch() == epoch && verifier.verified_in_current_epoch() >= count) {
        return status;
      }
    } else if (status == shm::PollStatus::empty) {
      std::this_thread::sleep_for(100us);
    }
  }
  return shm::PollStatus::empty;
}

// Reads and verifies what is left until the reader has caught up (nothing new for 10 ms).
void drain(shm::RingReader& reader, GroupVerifier& verifier) {
  std::vector<std::byte> buffer(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  auto quiet_since = Clock::now();
  while (Clock::now() - quiet_since < 10ms) {
    const shm::PollStatus status = reader.read_next(buffer, header);
    if (status == shm::PollStatus::ready) {
      verifier.check(header, buffer, reader.position() - 1, reader.epoch());
    }
    if (status != shm::PollStatus::empty) quiet_since = Clock::now();
  }
}

// Polls for `duration` and returns the statuses seen other than empty.
std::vector<shm::PollStatus> poll_for(shm::RingReader& reader, Clock::duration duration) {
  std::vector<std::byte> buffer(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  std::vector<shm::PollStatus> seen;
  const auto end = Clock::now() + duration;
  while (Clock::now() < end) {
    const shm::PollStatus status = reader.read_next(buffer, header);
    if (status != shm::PollStatus::empty) seen.push_back(status);
    std::this_thread::sleep_for(1ms);
  }
  return seen;
}

shm::PollStatus wait_for_producer_gone(shm::RingReader& reader, Clock::duration timeout = 10s) {
  std::vector<std::byte> buffer(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  const auto deadline = Clock::now() + timeout;
  shm::PollStatus status = shm::PollStatus::empty;
  while (Clock::now() < deadline) {
    status = reader.read_next(buffer, header);
    if (status == shm::PollStatus::producer_gone) break;
    std::this_thread::sleep_for(100us);
  }
  return status;
}

constexpr std::uint64_t kGroupsPerProducer = 50;

TEST(RingRestart, KilledProducerIsReplacedInPlaceAndTheReaderFollowsTheNewEpoch) {
  const ScopedShmName name("restart-killed");
  WriterPeer first = start_writer_peer(name.str());
  EXPECT_EQ(first.action, "created");
  shm::RingReader reader = attach_when_ready(name.str(), {}, Clock::now() + 30s);
  GroupVerifier verifier;
  ASSERT_EQ(consume(reader, verifier, kGroupsPerProducer, first.epoch), shm::PollStatus::ready);

  kill_writer_peer(first);
  // A dead producer's ring stays mapped and, once read to the end, simply has nothing new.
  drain(reader, verifier);
  EXPECT_TRUE(poll_for(reader, 50ms).empty());
  EXPECT_TRUE(shm::ShmObject::exists(name.str()));

  WriterPeer second = start_writer_peer(name.str());
  EXPECT_EQ(second.action, "reused_stale");
  EXPECT_NE(second.epoch, first.epoch);
  // The same reader, never re-attached, follows the new producer.
  ASSERT_EQ(consume(reader, verifier, kGroupsPerProducer, second.epoch), shm::PollStatus::ready);
  EXPECT_EQ(reader.epoch(), second.epoch);
  EXPECT_EQ(reader.counters().epoch_changes, 1u);
  EXPECT_EQ(verifier.failures(), 0u) << verifier.first_failure();

  close_writer_peer(second);
  EXPECT_EQ(wait_for_producer_gone(reader), shm::PollStatus::producer_gone);
}

TEST(RingRestart, OrderlyCloseTellsTheReaderToReattachToTheNewProducer) {
  const ScopedShmName name("restart-closed");
  WriterPeer first = start_writer_peer(name.str());
  shm::RingReader reader = attach_when_ready(name.str(), {}, Clock::now() + 30s);
  GroupVerifier verifier;
  ASSERT_EQ(consume(reader, verifier, kGroupsPerProducer, first.epoch), shm::PollStatus::ready);

  close_writer_peer(first);
  EXPECT_EQ(wait_for_producer_gone(reader), shm::PollStatus::producer_gone);
  EXPECT_FALSE(shm::ShmObject::exists(name.str())) << "close() unlinks the name";

  WriterPeer second = start_writer_peer(name.str());
  EXPECT_EQ(second.action, "created");
  // Re-attaching by assignment: the old reader's status object goes with it.
  const std::string old_status = *reader.status_object_name();
  reader = attach_when_ready(name.str(), {}, Clock::now() + 30s);
  EXPECT_FALSE(shm::ShmObject::exists(old_status));
  EXPECT_EQ(reader.epoch(), second.epoch);
  GroupVerifier second_verifier;
  ASSERT_EQ(consume(reader, second_verifier, kGroupsPerProducer, second.epoch),
            shm::PollStatus::ready);
  EXPECT_EQ(verifier.failures() + second_verifier.failures(), 0u)
      << verifier.first_failure() << second_verifier.first_failure();
  close_writer_peer(second);
}

TEST(RingRestart, ProducerOfAnotherLayoutRetiresTheOldObject) {
  const ScopedShmName name("restart-relayout");
  WriterPeer first = start_writer_peer(name.str());
  std::optional<shm::RingReader> reader;
  reader.emplace(attach_when_ready(name.str(), {}, Clock::now() + 30s));
  GroupVerifier verifier;
  ASSERT_EQ(consume(*reader, verifier, kGroupsPerProducer, first.epoch), shm::PollStatus::ready);
  kill_writer_peer(first);

  WriterPeer second = start_writer_peer(name.str(), {"--ascans", "8", "--slots", "16"});
  EXPECT_EQ(second.action, "replaced_stale");
  // The reader of the old object learns that it was retired.
  EXPECT_EQ(wait_for_producer_gone(*reader), shm::PollStatus::producer_gone);

  reader.reset();
  reader.emplace(attach_when_ready(name.str(), {}, Clock::now() + 30s));
  EXPECT_EQ(reader->geometry().ascans_per_bscan, 8u);
  EXPECT_EQ(reader->layout().slot_count, 16u);
  EXPECT_EQ(reader->layout().group_payload_bytes, 2 * small_test_geometry().group_payload_bytes());
  GroupVerifier second_verifier;
  ASSERT_EQ(consume(*reader, second_verifier, kGroupsPerProducer, second.epoch),
            shm::PollStatus::ready);
  EXPECT_EQ(verifier.failures() + second_verifier.failures(), 0u)
      << verifier.first_failure() << second_verifier.first_failure();
  close_writer_peer(second);
}

TEST(RingRestart, SecondProducerIsRefusedWhileTheFirstLives) {
  const ScopedShmName name("restart-live");
  WriterPeer live = start_writer_peer(name.str());
  shm::RingConfig same = small_test_config(name.str());
  shm::RingConfig other_layout = small_test_config(name.str(), 32);
  for (const shm::RingConfig& config : {same, other_layout}) {
    try {
      shm::RingWriter::create(config);
      ADD_FAILURE() << "a second producer was allowed to take over a live ring";
    } catch (const shm::RingError& e) {
      EXPECT_EQ(e.code(), shm::RingErrc::owned_by_live_producer) << e.what();
      EXPECT_NE(std::string(e.what()).find("pid " + std::to_string(live.process.pid())),
                std::string::npos)
          << e.what();
    }
  }
  // The refused attempts left the live ring alone: a reader still gets its groups.
  shm::RingReader reader = attach_when_ready(name.str(), {}, Clock::now() + 30s);
  EXPECT_EQ(reader.epoch(), live.epoch);
  GroupVerifier verifier;
  ASSERT_EQ(consume(reader, verifier, kGroupsPerProducer, live.epoch), shm::PollStatus::ready);
  EXPECT_EQ(verifier.failures(), 0u) << verifier.first_failure();
  close_writer_peer(live);
}

}  // namespace
}  // namespace ioct::ring_test
