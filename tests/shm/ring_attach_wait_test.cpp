// shm::attach_when_available, the wait every long-lived reader (ioct-gpu, ioct-record) runs for
// its producer: it waits through what a starting or restarting producer gives, reports while it
// waits, stops when asked, gives up after a bounded wait naming how long it waited, and refuses
// at once what waiting cannot cure.
#include <sys/stat.h>

#include <gtest/gtest.h>

#include <atomic>
#include <optional>
#include <string>
#include <vector>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/shm/ring_attach.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

TEST(RingAttachWait, ABoundedWaitForAMissingRingGivesUpNamingTheWait) {
  const test_support::ScopedShmName name("attach-bounded");
  shm::AttachWait wait;
  wait.deadline_ns = ioct::monotonic_ns();  // already past: one try, then give up
  wait.retry_interval_ns = 1'000'000;
  try {
    shm::attach_when_available(name.str(), {.label = "attach-test"}, wait, 0.25);
    FAIL() << "attached to a ring that does not exist";
  } catch (const shm::RingError& e) {
    EXPECT_EQ(e.code(), shm::RingErrc::not_found);
    EXPECT_NE(std::string(e.what()).find("ring '" + name.str() + "' not readable after 0.25 s"),
              std::string::npos)
        << e.what();
  }
}

TEST(RingAttachWait, AnUnboundedWaitReportsThenAttachesWhenTheProducerComes) {
  const test_support::ScopedShmName name("attach-unbounded");
  std::optional<shm::RingWriter> writer;
  std::vector<shm::RingErrc> reports;
  shm::AttachWait wait;
  wait.unbounded = true;
  wait.retry_interval_ns = 1'000'000;
  wait.report_interval_ns = 1;  // every retry
  // The producer starts only once the wait has reported: the order is fixed, not timed.
  wait.on_waiting = [&](shm::RingErrc last, std::uint64_t) {
    reports.push_back(last);
    if (!writer) writer.emplace(shm::RingWriter::create(small_test_config(name.str(), 4)));
  };
  std::optional<shm::RingReader> reader =
      shm::attach_when_available(name.str(), {.label = "attach-test"}, wait);
  ASSERT_TRUE(reader.has_value());
  ASSERT_FALSE(reports.empty());
  EXPECT_EQ(reports.front(), shm::RingErrc::not_found);
  EXPECT_EQ(reader->geometry(), writer->config().geometry);
}

TEST(RingAttachWait, AStopRequestEndsAnUnboundedWait) {
  const test_support::ScopedShmName name("attach-stop");
  std::atomic<bool> stop{false};
  shm::AttachWait wait;
  wait.unbounded = true;
  wait.stop = &stop;
  wait.retry_interval_ns = 1'000'000;
  wait.report_interval_ns = 1;
  wait.on_waiting = [&](shm::RingErrc, std::uint64_t) { stop = true; };  // e.g. SIGTERM
  EXPECT_FALSE(shm::attach_when_available(name.str(), {.label = "attach-test"}, wait).has_value());
}

TEST(RingAttachWait, WhatWaitingCannotCureIsRefusedAtOnce) {
  const test_support::ScopedShmName name("attach-fifo");
  ASSERT_EQ(::mkfifo(("/dev/shm/" + name.str()).c_str(), 0600), 0);
  shm::AttachWait wait;
  wait.unbounded = true;  // a retry would never end
  try {
    shm::attach_when_available(name.str(), {.label = "attach-test"}, wait);
    FAIL() << "attached to a FIFO";
  } catch (const shm::RingError& e) {
    EXPECT_EQ(e.code(), shm::RingErrc::squatted) << e.what();
  }
  EXPECT_FALSE(shm::attach_worth_retrying(shm::RingErrc::squatted));
  EXPECT_TRUE(shm::attach_worth_retrying(shm::RingErrc::producer_gone));
}

}  // namespace
}  // namespace ioct::ring_test
