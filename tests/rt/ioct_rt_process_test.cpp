// ioct-rt as a process: it fills the ring until SIGTERM or SIGINT and then removes it, refuses a
// ring another producer owns, and exits non-zero on bad options.
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/shm_object.hpp"
#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/not_realtime.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "ioct/test_support/small_rt_run.hpp"

namespace ioct {
namespace {

using namespace std::chrono_literals;
using test_support::ChildProcess;

std::vector<std::string> small_run(const std::string& ring, std::vector<std::string> extra = {}) {
  extra.insert(extra.begin(), {"--status-interval", "0.2"});
  return test_support::small_rt_run(ring, extra);
}

ChildProcess start_rt(const std::vector<std::string>& arguments) {
  return ChildProcess::spawn(test_support::sibling_executable("ioct-rt"), arguments);
}

std::optional<shm::RingReader> attach_when_live(const std::string& ring,
                                                std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    try {
      return shm::RingReader::attach(ring, {.label = "process-test"});
    } catch (const shm::RingError&) {
      std::this_thread::sleep_for(10ms);  // not created or not initialised yet
    }
  }
  return std::nullopt;
}

// Reads `count` groups; returns how many arrived before `timeout`.
std::uint64_t read_groups(shm::RingReader& reader, std::uint64_t count,
                          std::chrono::milliseconds timeout, std::uint32_t* flags = nullptr) {
  std::vector<std::byte> payload(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  std::uint64_t read = 0;
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (read < count && std::chrono::steady_clock::now() < end) {
    if (reader.read_next(payload, header) == shm::PollStatus::ready) {
      ++read;
      if (flags != nullptr) *flags |= header.status_flags;
    } else {
      std::this_thread::sleep_for(1ms);
    }
  }
  return read;
}

int exit_code(const std::optional<int>& status) {
  if (!status.has_value()) return -1000;  // still running
  return WIFEXITED(*status) ? WEXITSTATUS(*status) : -WTERMSIG(*status);
}

class IoctRtProcess : public testing::TestWithParam<int> {};

TEST_P(IoctRtProcess, FillsTheRingUntilSignalledThenRemovesItAndExitsZero) {
  const test_support::ScopedShmName ring("rt-process");
  const std::filesystem::path summary =
      std::filesystem::temp_directory_path() / ("ioct-rt-summary-" + std::to_string(::getpid()) +
                                                "-" + std::to_string(GetParam()) + ".json");
  ChildProcess rt = start_rt(small_run(ring.str(), {"--summary", summary.string()}));
  std::optional<shm::RingReader> reader = attach_when_live(ring.str(), 20s);
  ASSERT_TRUE(reader.has_value()) << "ioct-rt never created ring " << ring.str();
  std::uint32_t flags = 0;
  EXPECT_EQ(read_groups(*reader, 10, 20s, &flags), 10u);
  EXPECT_EQ(flags & (shm::kStatusSimulated | shm::kStatusLaserOn),
            shm::kStatusSimulated | shm::kStatusLaserOn);

  rt.send_signal(GetParam());
  const std::optional<int> status = rt.wait_for(10s);
  ASSERT_TRUE(status.has_value()) << "ioct-rt did not stop";
  EXPECT_EQ(exit_code(status), 0) << test_support::describe_wait_status(*status);
  EXPECT_FALSE(shm::ShmObject::exists(ring.str()));
  std::vector<std::byte> payload(reader->layout().group_payload_bytes);
  shm::SlotHeader header{};
  shm::PollStatus poll = shm::PollStatus::ready;
  while (poll == shm::PollStatus::ready) poll = reader->read_next(payload, header);
  EXPECT_EQ(poll, shm::PollStatus::producer_gone);

  // The signal took the stop path: emission off, then the galvos parked, then the ring closed.
  std::ifstream in(summary);
  const nlohmann::json s = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(s.is_discarded()) << "no summary at " << summary;
  std::filesystem::remove(summary);
  const nlohmann::json& safety = s["status"]["safety"];
  EXPECT_EQ(safety["state"], "idle");
  EXPECT_EQ(safety["emission_readback"], false);
  EXPECT_EQ(safety["faults_total"], 0);
  const double off_ms = safety["emission_off_after_fault_ms"].get<double>();
  const double parked_ms = safety["parked_after_fault_ms"].get<double>();
  std::printf("[ bound    ] stop by signal %d: emission off %.2f ms, galvos parked %.2f ms\n",
              GetParam(), off_ms, parked_ms);
  // Not real-time here (--rt-priority 0): the documented 2 ms and ~100 ms, each with the
  // not-real-time allowance (a sanitizer's build parked 226.6 ms after the stop in CI).
  const double allowance_ms = static_cast<double>(test_support::kNotRealtimeAllowanceNs) / 1e6;
  EXPECT_LE(off_ms, 2.0 + allowance_ms);
  EXPECT_LE(parked_ms, 100.0 + allowance_ms);
  EXPECT_LE(off_ms, parked_ms);
  EXPECT_EQ(s["stop_reason"], GetParam() == SIGTERM ? "stopped by SIGTERM" : "stopped by SIGINT");
}

INSTANTIATE_TEST_SUITE_P(Signals, IoctRtProcess, testing::Values(SIGTERM, SIGINT),
                         [](const testing::TestParamInfo<int>& signal) {
                           return signal.param == SIGTERM ? std::string("SIGTERM")
                                                          : std::string("SIGINT");
                         });

TEST(IoctRtProcessAlone, StopsByItselfAfterSeconds) {
  const test_support::ScopedShmName ring("rt-seconds");
  ChildProcess rt = start_rt(small_run(ring.str(), {"--seconds", "0.5"}));
  const std::optional<int> status = rt.wait_for(20s);
  ASSERT_TRUE(status.has_value()) << "ioct-rt did not stop after --seconds";
  EXPECT_EQ(exit_code(status), 0) << test_support::describe_wait_status(*status);
  EXPECT_FALSE(shm::ShmObject::exists(ring.str()));
}

// Issue F1: a FIFO planted among the readers' status objects (any local user may do so in
// /dev/shm) used to block the housekeeping thread in its reader scan: no status, no watchdog,
// SIGTERM not acted on. Now the scan skips it, and SIGTERM still ends the run at once.
TEST(IoctRtProcessAlone, AFifoAmongTheReadersStatusObjectsBlocksNothing) {
  const test_support::ScopedShmName ring("rt-fifo");
  ChildProcess rt = start_rt(small_run(ring.str()));
  ASSERT_TRUE(attach_when_live(ring.str(), 20s).has_value());
  ASSERT_EQ(::mkfifo(("/dev/shm/" + ring.str() + ".reader.999.0").c_str(), 0644), 0);
  std::this_thread::sleep_for(1s);  // several status intervals: each scans the readers
  const auto signalled = std::chrono::steady_clock::now();
  rt.send_signal(SIGTERM);
  const std::optional<int> status = rt.wait_for(10s);
  ASSERT_TRUE(status.has_value()) << "SIGTERM not acted on: the housekeeping thread is blocked";
  EXPECT_EQ(exit_code(status), 0) << test_support::describe_wait_status(*status);
  EXPECT_LT(std::chrono::steady_clock::now() - signalled, 5s);
}

TEST(IoctRtProcessAlone, RefusesARingThatAnotherProducerOwns) {
  const test_support::ScopedShmName ring("rt-owned");
  ChildProcess first = start_rt(small_run(ring.str()));
  std::optional<shm::RingReader> reader = attach_when_live(ring.str(), 20s);
  ASSERT_TRUE(reader.has_value());

  ChildProcess second = start_rt(small_run(ring.str()));
  const std::optional<int> refused = second.wait_for(20s);
  ASSERT_TRUE(refused.has_value()) << "the second producer kept running";
  EXPECT_EQ(exit_code(refused), 1) << test_support::describe_wait_status(*refused);

  // The owner goes on undisturbed.
  EXPECT_EQ(read_groups(*reader, 5, 20s), 5u);
  EXPECT_EQ(reader->counters().epoch_changes, 0u);
  first.send_signal(SIGTERM);
  EXPECT_EQ(exit_code(first.wait_for(10s)), 0);
}

TEST(IoctRtProcessAlone, BadOptionsExitNonZeroWithoutCreatingTheRing) {
  const test_support::ScopedShmName ring("rt-bad");
  const std::vector<std::vector<std::string>> bad = {
      {"--samples", "1377"},          // odd
      {"--bscans-per-group", "100"},  // more than a slot's markers
      {"--slots", "1"},
      {"--ascan-rate", "0"},
      {"--ascans", "-3"},
      {"--no-such-option"},
  };
  for (const std::vector<std::string>& extra : bad) {
    SCOPED_TRACE(extra.front());
    ChildProcess rt = start_rt(small_run(ring.str(), extra));
    const std::optional<int> status = rt.wait_for(20s);
    ASSERT_TRUE(status.has_value());
    EXPECT_GT(exit_code(status), 0) << test_support::describe_wait_status(*status);
    EXPECT_FALSE(shm::ShmObject::exists(ring.str()));
  }
}

}  // namespace
}  // namespace ioct
