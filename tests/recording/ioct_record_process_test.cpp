// ioct-record as a process beside a simulated ioct-rt: the groups in its file are the bytes the
// ring published (compared with what a second reader of the same ring copied), a viewer reads
// the file while it grows, a SIGKILL leaves
// a file that opens with every group written before it, a full disk (here: --max-mb) gives
// counted drops and a message, and a restarted producer is followed into the same file.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "ioct/common/line_client.hpp"
#include "ioct/ringrec/ring_recording_format.hpp"
#include "ioct/ringrec/ring_recording_reader.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "ioct/test_support/temp_path.hpp"
#include "recording_processes.hpp"

namespace ioct::ringrec {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using test_support::ChildProcess;

using test::small_rt;
using test::start;

std::vector<std::string> record_args(const std::string& ring, const fs::path& out,
                                     std::vector<std::string> extra = {}) {
  std::vector<std::string> arguments = {
      "--ring", ring, "--out", out.string(), "--wait", "30", "--status-interval", "0.1"};
  arguments.insert(arguments.end(), extra.begin(), extra.end());
  return arguments;
}

int exit_code(const std::optional<int>& status) {
  if (!status.has_value()) return -1000;  // still running
  return WIFEXITED(*status) ? WEXITSTATUS(*status) : -WTERMSIG(*status);
}

std::uint64_t counter(const RingRecordingReader& reader, Counter which) {
  return reader.counters()[static_cast<std::size_t>(which)];
}

// A second reader of the ring that keeps the first `limit` groups it copies intact, by
// (epoch, group index): what the ring published, to compare the recording with.
class RingCapture {
 public:
  RingCapture(std::string ring, std::size_t limit) : ring_(std::move(ring)), limit_(limit) {
    thread_ = std::thread([this] { run(); });
  }
  ~RingCapture() {
    stop_ = true;
    thread_.join();
  }
  // The captured group, or nullptr.
  const std::vector<std::byte>* find(std::uint64_t epoch, std::uint64_t group) {
    std::lock_guard lock(mutex_);
    const auto it = groups_.find({epoch, group});
    return it == groups_.end() ? nullptr : &it->second;
  }
  bool attached() const { return attached_; }

 private:
  void run() {
    std::optional<shm::RingReader> reader;
    std::vector<std::byte> payload;
    shm::SlotHeader header{};
    while (!stop_) {
      if (!reader) {
        try {
          reader = shm::RingReader::attach(ring_, {.label = "record-test"});
          payload.resize(reader->layout().group_payload_bytes);
          attached_ = true;
        } catch (const shm::RingError&) {
          std::this_thread::sleep_for(5ms);
          continue;
        }
      }
      const shm::PollStatus poll = reader->read_next(payload, header);
      if (poll == shm::PollStatus::ready) {
        std::lock_guard lock(mutex_);
        if (groups_.size() < limit_) groups_[{header.producer_epoch, header.group_index}] = payload;
      } else if (poll == shm::PollStatus::producer_gone) {
        reader.reset();
      } else {
        std::this_thread::sleep_for(1ms);
      }
    }
  }

  std::string ring_;
  std::size_t limit_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> attached_{false};
  std::mutex mutex_;
  std::map<std::pair<std::uint64_t, std::uint64_t>, std::vector<std::byte>> groups_;
  std::thread thread_;
};

// Reads the recorder's stdout until a status line says at least `groups` were written; returns
// false when it ends or stalls first. The lines seen are appended to `seen`.
bool wait_for_groups_written(ChildProcess& recorder, std::uint64_t groups, std::string& seen) {
  while (std::optional<std::string> line = recorder.read_line(60s)) {
    seen += *line + "\n";
    const std::size_t at = line->find(" groups written");
    if (at == std::string::npos) continue;
    const std::size_t begin = line->rfind(' ', at - 1);
    if (std::stoull(line->substr(begin + 1, at - begin - 1)) >= groups) return true;
  }
  return false;
}

// SIGTERM to a recorder, which must finish its file and exit 0.
void stop_recorder(ChildProcess& recorder) {
  recorder.send_signal(SIGTERM);
  const std::optional<int> status = recorder.wait_for(30s);
  ASSERT_EQ(exit_code(status), 0) << (status ? test_support::describe_wait_status(*status) : "");
}

// A finished file of at least `groups` groups that counts exactly the groups it holds.
void expect_finished_file(const RingRecordingReader& reader, std::uint64_t groups) {
  EXPECT_TRUE(reader.finished());
  EXPECT_GE(reader.group_count(), groups);
  EXPECT_EQ(counter(reader, Counter::groups_written), reader.group_count());
}

// Every group in the file is intact (checksum), and equal to the ring's where the second reader
// copied it too. Returns how many were compared with the ring.
std::uint64_t compare_with_ring(const RingRecordingReader& reader, RingCapture& capture) {
  std::vector<std::byte> payload(reader.group_bytes());
  shm::SlotHeader header{};
  std::uint64_t compared = 0;
  std::uint64_t previous = 0;
  for (std::uint64_t i = 0; i < reader.group_count(); ++i) {
    reader.read_group(i, payload, header);
    EXPECT_EQ(header.payload_bytes, reader.group_bytes());
    if (i > 0 && header.group_index != 0) {
      EXPECT_GT(header.group_index, previous) << "file group " << i << " out of order";
    }
    previous = header.group_index;
    if (const std::vector<std::byte>* ring =
            capture.find(header.producer_epoch, header.group_index)) {
      EXPECT_TRUE(*ring == payload) << "file group " << i << " (ring group " << header.group_index
                                    << ") differs from the ring's bytes";
      ++compared;
    }
  }
  return compared;
}

TEST(IoctRecord, RecordsTheRingsGroupsByteForByteAndFinishesCleanlyOnSigterm) {
  const test_support::ScopedShmName ring("record");
  const test_support::TempPath out("record-sigterm", ".h5");
  ChildProcess rt = start("ioct-rt", small_rt(ring.str()));
  RingCapture capture(ring.str(), 400);
  ChildProcess recorder = start("ioct-record", record_args(ring.str(), out.path()));
  std::string lines;
  ASSERT_TRUE(wait_for_groups_written(recorder, 40, lines)) << lines;
  {
    // A viewer reads the file while it grows (SWMR), and sees the groups appended since.
    RingRecordingReader live(out.path());
    EXPECT_FALSE(live.finished());
    const std::uint64_t seen = live.group_count();
    ASSERT_GE(seen, 40u);
    std::vector<std::byte> payload(live.group_bytes());
    shm::SlotHeader header{};
    live.read_group(seen - 1, payload, header);
    ASSERT_TRUE(wait_for_groups_written(recorder, seen + 10, lines)) << lines;
    EXPECT_GE(live.refresh(), seen + 10);
    live.read_group(live.group_count() - 1, payload, header);
  }
  ASSERT_NO_FATAL_FAILURE(stop_recorder(recorder));
  const RingRecordingReader reader(out.path());
  ASSERT_NO_FATAL_FAILURE(expect_finished_file(reader, 40));
  EXPECT_EQ(reader.geometry().samples_per_ascan, 256u);
  EXPECT_EQ(reader.ring_name(), ring.str());
  EXPECT_EQ(reader.ring_producer_pid(), static_cast<std::uint64_t>(rt.pid()))
      << "the recording names the process that produced the ring";
  const std::uint64_t compared = compare_with_ring(reader, capture);
  std::printf("[ compared ] %llu of %llu recorded groups against the ring's bytes\n",
              static_cast<unsigned long long>(compared),
              static_cast<unsigned long long>(reader.group_count()));
  EXPECT_GE(compared, 10u) << "too few groups seen by both readers to compare";
}

// A recorder that stalls (SIGSTOP: a stuck disk, a descheduled process) falls more than a ring
// behind the producer. It counts the groups it lost (skipped to the ring's newest: "behind"; a
// copy overwritten under it: "lapped"), goes on and records on; the file counts the loss, and
// every group in it is whole and the ring's.
TEST(IoctRecord, AStalledRecorderCountsTheGroupsItLostAndRecordsOn) {
  const test_support::ScopedShmName ring("record-stalled");
  const test_support::TempPath out("record-stalled", ".h5");
  std::vector<std::string> rt_arguments = small_rt(ring.str());
  rt_arguments.insert(rt_arguments.end(), {"--slots", "4"});
  ChildProcess rt = start("ioct-rt", rt_arguments);
  RingCapture capture(ring.str(), 400);
  ChildProcess recorder = start("ioct-record", record_args(ring.str(), out.path()));
  std::string lines;
  ASSERT_TRUE(wait_for_groups_written(recorder, 10, lines)) << lines;
  // Every group the recorder says it lost so far (a loaded machine may lose some before the
  // stall), from its status lines.
  const auto lost_in = [](const std::string& line) -> std::optional<std::uint64_t> {
    if (line.find("lost: ") == std::string::npos) return std::nullopt;
    std::uint64_t sum = 0;
    for (const char* what : {"lapped ", "behind ", "queue full ", "disk full "}) {
      const std::size_t at = line.find(what);
      if (at != std::string::npos) sum += std::stoull(line.substr(at + std::strlen(what)));
    }
    return sum;
  };
  std::uint64_t lost_before = 0;
  std::istringstream seen(lines);
  for (std::string line; std::getline(seen, line);)
    lost_before = lost_in(line).value_or(lost_before);
  // Stalled for 0.5 s: the simulator publishes about 80 groups into the 4 slots meanwhile.
  recorder.send_signal(SIGSTOP);
  std::this_thread::sleep_for(500ms);
  recorder.send_signal(SIGCONT);
  // It records on: a status line that counts more loss than before the stall, then more groups.
  std::uint64_t lost = lost_before;
  const auto give_up = std::chrono::steady_clock::now() + 30s;
  while (lost <= lost_before && std::chrono::steady_clock::now() < give_up) {
    const std::optional<std::string> line = recorder.read_line(10s);
    if (!line) break;
    lines += *line + "\n";
    lost = lost_in(*line).value_or(lost);
  }
  EXPECT_GT(lost, lost_before) << "no loss counted after the stall:\n" << lines;
  ASSERT_TRUE(wait_for_groups_written(recorder, 40, lines)) << lines;
  ASSERT_NO_FATAL_FAILURE(stop_recorder(recorder));
  const RingRecordingReader reader(out.path());
  ASSERT_NO_FATAL_FAILURE(expect_finished_file(reader, 40));
  const std::uint64_t counted =
      counter(reader, Counter::dropped_lapped) + counter(reader, Counter::dropped_behind) +
      counter(reader, Counter::dropped_queue_full) + counter(reader, Counter::dropped_disk_full);
  EXPECT_GE(counted, lost) << "the file counts the loss";
  // The stall shows in the file as a jump in the ring's group indices, no larger than the loss.
  std::vector<std::byte> payload(reader.group_bytes());
  shm::SlotHeader header{};
  std::uint64_t previous = 0, largest_jump = 0;
  for (std::uint64_t i = 0; i < reader.group_count(); ++i) {
    reader.read_group(i, payload, header);
    if (i > 0) largest_jump = std::max(largest_jump, header.group_index - previous);
    previous = header.group_index;
  }
  EXPECT_GT(largest_jump, 4u) << "the stall lost more groups than the ring's 4 slots hold";
  EXPECT_LE(largest_jump - 1, counted) << "every group missing from the file is counted";
  const std::uint64_t compared = compare_with_ring(reader, capture);
  std::printf(
      "[ stalled  ] %llu groups lost (lapped %llu, behind %llu), the largest jump %llu; "
      "%llu of %llu recorded groups compared with the ring's bytes\n",
      static_cast<unsigned long long>(counted),
      static_cast<unsigned long long>(counter(reader, Counter::dropped_lapped)),
      static_cast<unsigned long long>(counter(reader, Counter::dropped_behind)),
      static_cast<unsigned long long>(largest_jump), static_cast<unsigned long long>(compared),
      static_cast<unsigned long long>(reader.group_count()));
  EXPECT_GE(compared, 10u);
}

TEST(IoctRecord, SigkillLeavesAFileWithEveryGroupWrittenBeforeIt) {
  const test_support::ScopedShmName ring("record-kill");
  const test_support::TempPath out("record-sigkill", ".h5");
  ChildProcess rt = start("ioct-rt", small_rt(ring.str()));
  RingCapture capture(ring.str(), 400);
  ChildProcess recorder = start("ioct-record", record_args(ring.str(), out.path()));
  std::string lines;
  ASSERT_TRUE(wait_for_groups_written(recorder, 20, lines)) << lines;
  recorder.kill_and_wait();

  const RingRecordingReader reader(out.path());  // opens with no h5clear: SWMR read
  EXPECT_FALSE(reader.finished());
  // Every group the last status line counted was flushed before that line was printed.
  EXPECT_GE(reader.group_count(), 20u);
  EXPECT_LE(counter(reader, Counter::groups_written), reader.group_count() + 1);
  const std::uint64_t compared = compare_with_ring(reader, capture);
  EXPECT_GE(compared, 5u);
}

TEST(IoctRecord, AFullDiskGivesCountedDropsAndAClearMessage) {
  const test_support::ScopedShmName ring("record-full");
  const test_support::TempPath out("record-full", ".h5");
  ChildProcess rt = start("ioct-rt", small_rt(ring.str()));
  // Room for 5 groups of 262144 + 2136 bytes.
  ChildProcess recorder =
      start("ioct-record", record_args(ring.str(), out.path(), {"--max-mb", "1.4"}));
  std::string lines;
  bool said = false;
  while (std::optional<std::string> line = recorder.read_line(60s)) {
    lines += *line + "\n";
    if (line->find("--max-bytes 1400000") != std::string::npos &&
        line->find("counted as dropped_disk_full") != std::string::npos) {
      said = true;
    }
    const std::size_t at = line->find("disk full ");
    if (said && at != std::string::npos && line->substr(at + 10, 1) != "0") break;
  }
  ASSERT_TRUE(said) << lines;
  recorder.send_signal(SIGTERM);
  ASSERT_EQ(exit_code(recorder.wait_for(30s)), 0);

  const RingRecordingReader reader(out.path());
  EXPECT_TRUE(reader.finished());
  EXPECT_EQ(reader.group_count(), 5u);
  EXPECT_GT(counter(reader, Counter::dropped_disk_full), 0u);
  EXPECT_LE(counter(reader, Counter::bytes_written), 1'400'000u);
}

TEST(IoctRecord, FollowsARestartedProducerIntoTheSameFile) {
  const test_support::ScopedShmName ring("record-restart");
  const test_support::TempPath out("record-restart", ".h5");
  std::optional<ChildProcess> rt(start("ioct-rt", small_rt(ring.str())));
  ChildProcess recorder = start("ioct-record", record_args(ring.str(), out.path()));
  std::string lines;
  ASSERT_TRUE(wait_for_groups_written(recorder, 10, lines)) << lines;
  rt->send_signal(SIGTERM);
  ASSERT_EQ(exit_code(rt->wait_for(30s)), 0);
  rt.reset();
  rt.emplace(start("ioct-rt", small_rt(ring.str())));
  bool back = false;
  while (std::optional<std::string> line = recorder.read_line(60s)) {
    lines += *line + "\n";
    if (line->find("producer back") != std::string::npos) back = true;
    if (back && line->find(" groups written") != std::string::npos) break;
  }
  ASSERT_TRUE(back) << lines;
  ASSERT_TRUE(wait_for_groups_written(recorder, 30, lines)) << lines;
  recorder.send_signal(SIGINT);
  ASSERT_EQ(exit_code(recorder.wait_for(30s)), 0);

  const RingRecordingReader reader(out.path());
  EXPECT_GE(counter(reader, Counter::producer_restarts), 1u);
  std::vector<std::byte> payload(reader.group_bytes());
  shm::SlotHeader first{}, last{};
  reader.read_group(0, payload, first);
  reader.read_group(reader.group_count() - 1, payload, last);
  EXPECT_NE(first.producer_epoch, last.producer_epoch) << "no group of the second producer";
}

// Records a simulated ioct-rt run on `ring` into `path` until `groups` are written (then
// SIGTERM, a clean finish).
void record_simulated_run(const std::string& ring, const fs::path& path, std::uint64_t groups) {
  ChildProcess rt = start("ioct-rt", small_rt(ring));
  ChildProcess recorder = start("ioct-record", record_args(ring, path));
  std::string lines;
  ASSERT_TRUE(wait_for_groups_written(recorder, groups, lines)) << lines;
  recorder.send_signal(SIGTERM);
  ASSERT_EQ(exit_code(recorder.wait_for(30s)), 0);
}

// The recording's groups by their first sweep counter (a replay's groups are found by it).
std::map<std::uint64_t, std::uint64_t> groups_by_first_sweep(const RingRecordingReader& recorded) {
  std::map<std::uint64_t, std::uint64_t> by_sweep;
  shm::SlotHeader header{};
  for (std::uint64_t i = 0; i < recorded.group_count(); ++i) {
    recorded.read_header(i, header);
    by_sweep[header.first_sweep_counter] = i;
  }
  return by_sweep;
}

TEST(IoctRecord, ReplayThroughIoctRtPublishesTheRecordedGroupsBitForBit) {
  const test_support::ScopedShmName ring("record-live");
  const test_support::ScopedShmName replay_ring("record-replay");
  const test_support::TempPath out("record-replay", ".h5");
  ASSERT_NO_FATAL_FAILURE(record_simulated_run(ring.str(), out.path(), 60));
  const RingRecordingReader recorded(out.path());
  const std::map<std::uint64_t, std::uint64_t> by_sweep = groups_by_first_sweep(recorded);
  shm::SlotHeader header{};

  std::vector<std::string> arguments = small_rt(replay_ring.str());
  // Played at a fifth of the recorded rate (the ring recording leaves the timing to the
  // config), so that this reader, slow under ThreadSanitizer, keeps up with most groups; the
  // replay outlasts the safety's 2 s arming timeout, so the loop must reach scanning.
  arguments.insert(arguments.end(),
                   {"--replay", out.path().string(), "--replay-once", "--ascan-rate", "20000"});
  ChildProcess replay = start("ioct-rt", arguments);
  std::optional<shm::RingReader> reader;
  for (int tries = 0; tries < 3000 && !reader; ++tries) {
    try {
      reader = shm::RingReader::attach(replay_ring.str(), {.label = "replay-test"});
    } catch (const shm::RingError&) {
      std::this_thread::sleep_for(2ms);
    }
  }
  ASSERT_TRUE(reader.has_value()) << "the replaying ioct-rt never created its ring";
  std::vector<std::byte> live(reader->layout().group_payload_bytes);
  std::vector<std::byte> file(recorded.group_bytes());
  std::uint64_t compared = 0;
  std::uint32_t flags = 0;
  const auto end = std::chrono::steady_clock::now() + 60s;
  while (compared < recorded.group_count() && std::chrono::steady_clock::now() < end) {
    const shm::PollStatus poll = reader->read_next(live, header);
    if (poll == shm::PollStatus::producer_gone) break;
    if (poll != shm::PollStatus::ready) {
      std::this_thread::sleep_for(1ms);
      continue;
    }
    flags |= header.status_flags;
    const auto it = by_sweep.find(header.first_sweep_counter);
    if (it == by_sweep.end()) break;  // past the recording's end (--replay-once)
    shm::SlotHeader recorded_header{};
    recorded.read_group(it->second, file, recorded_header);
    EXPECT_TRUE(live == file) << "replayed group " << header.group_index << " (file group "
                              << it->second << ") differs from the recording";
    EXPECT_EQ(header.missed_sweeps, recorded_header.missed_sweeps);
    ++compared;
    // --replay-once: nothing follows the recording's last group (a slow reader may have lost
    // some before it, counted as lapped, not compared).
    if (it->second + 1 == recorded.group_count()) break;
  }
  std::printf("[ compared ] %llu replayed groups of %llu recorded, bit for bit\n",
              static_cast<unsigned long long>(compared),
              static_cast<unsigned long long>(recorded.group_count()));
  EXPECT_GE(compared, 10u);
  EXPECT_NE(flags & shm::kStatusReplay, 0u) << "the ring does not say it is a replay";
  EXPECT_NE(flags & shm::kStatusLaserOn, 0u) << "the replay never reached scanning";
  EXPECT_EQ(flags & shm::kStatusSimulated, 0u);
  replay.send_signal(SIGTERM);
  EXPECT_EQ(exit_code(replay.wait_for(30s)), 0);
}

// A recording found corrupt half-way: the replay stops at that group, and ioct-rt says which and
// why, in its summary (before, it read as the recording's end: the digitizer gone, no reason).
TEST(IoctRecord, AReplayStoppedByACorruptGroupSaysWhichAndWhy) {
  const test_support::ScopedShmName ring("record-corrupt-live");
  const test_support::ScopedShmName replay_ring("record-corrupt");
  const test_support::TempPath out("record-corrupt", ".h5");
  const test_support::TempPath summary("record-corrupt-summary", ".json");
  ASSERT_NO_FATAL_FAILURE(record_simulated_run(ring.str(), out.path(), 12));
  {
    // Group 3's recorded checksum no longer matches its samples.
    const hid_t file = H5Fopen(out.path().c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    const hid_t set = H5Dopen2(file, kChecksumsDataset, H5P_DEFAULT);
    ASSERT_GE(set, 0);
    const hid_t space = H5Dget_space(set);
    const hsize_t start[1] = {3}, count[1] = {1};
    const hid_t one = H5Screate_simple(1, count, nullptr);
    H5Sselect_hyperslab(space, H5S_SELECT_SET, start, nullptr, count, nullptr);
    std::uint64_t checksum = 0;
    ASSERT_GE(H5Dread(set, H5T_NATIVE_UINT64, one, space, H5P_DEFAULT, &checksum), 0);
    checksum = ~checksum;
    ASSERT_GE(H5Dwrite(set, H5T_NATIVE_UINT64, one, space, H5P_DEFAULT, &checksum), 0);
    H5Sclose(one);
    H5Sclose(space);
    H5Dclose(set);
    H5Fclose(file);
  }
  const test_support::TempPath socket("record-corrupt-control", ".sock");
  std::vector<std::string> arguments = small_rt(replay_ring.str());
  arguments.insert(arguments.end(),
                   {"--replay", out.path().string(), "--replay-once", "--seconds", "3", "--summary",
                    summary.path().string(), "--control-socket", socket.path().string()});
  ChildProcess replay = start("ioct-rt", arguments);
  using ioct::LineClient;
  // While it runs, its live status says why the groups stopped (group 3 comes well within 3 s).
  std::string live_error;
  std::optional<int> ended;
  LineClient control(socket.path().string(), 2s);
  for (auto end = std::chrono::steady_clock::now() + 20s;
       live_error.empty() && std::chrono::steady_clock::now() < end &&
       !(ended = replay.wait_for(0ms)).has_value();
       std::this_thread::sleep_for(20ms)) {
    const std::optional<std::string> line = control.request(R"({"cmd":"status"})");
    if (!line) continue;
    const nlohmann::json reply = nlohmann::json::parse(*line, nullptr, false);
    const nlohmann::json* status = &reply;
    if (reply.contains("status")) status = &reply["status"];
    if (status->contains("acquisition")) {
      live_error = (*status)["acquisition"].value("replay_error", "");
    }
  }
  EXPECT_NE(live_error.find(": group 3 at byte "), std::string::npos)
      << "the live status never said why: '" << live_error << "'";
  if (!ended) ended = replay.wait_for(60s);
  ASSERT_TRUE(ended.has_value()) << "ioct-rt did not end after its 3 s";
  std::ifstream in(summary.path());
  const nlohmann::json s = nlohmann::json::parse(in, nullptr, false);
  ASSERT_TRUE(s.is_object()) << "no summary at " << summary.path();
  const std::string error = s.value("replay_error", "");
  std::printf("[ message  ] %s\n", error.c_str());
  EXPECT_NE(error.find(out.path().string() + ": group 3 at byte "), std::string::npos) << error;
  EXPECT_NE(error.find("(corrupt chunk)"), std::string::npos) << error;
}

// --replay-speed 4: the loop stamps and publishes the groups four times as fast as the
// recorded rate, with the recorded bytes. The stamps follow the loop's paced clock exactly; the
// publication times only loosely (at least twice real time), so a slow machine cannot fail it.
TEST(IoctRecord, ReplaySpeedPacesTheGroupsFasterAndKeepsThemBitForBit) {
  const test_support::ScopedShmName ring("record-speed-live");
  const test_support::ScopedShmName replay_ring("record-speed");
  const test_support::TempPath out("record-speed", ".h5");
  ASSERT_NO_FATAL_FAILURE(record_simulated_run(ring.str(), out.path(), 40));
  const RingRecordingReader recorded(out.path());
  const std::map<std::uint64_t, std::uint64_t> by_sweep = groups_by_first_sweep(recorded);
  shm::SlotHeader header{};

  constexpr double kSpeed = 4.0;
  constexpr double kAscanRateHz = 10000.0;  // recorded rate: 1 group per 64 ms or more
  std::vector<std::string> arguments = small_rt(replay_ring.str());
  arguments.insert(arguments.end(), {"--replay", out.path().string(), "--replay-once",
                                     "--ascan-rate", "10000", "--replay-speed", "4"});
  ChildProcess replay = start("ioct-rt", arguments);
  std::optional<shm::RingReader> reader;
  for (int tries = 0; tries < 3000 && !reader; ++tries) {
    try {
      reader = shm::RingReader::attach(replay_ring.str(), {.label = "replay-speed-test"});
    } catch (const shm::RingError&) {
      std::this_thread::sleep_for(2ms);
    }
  }
  ASSERT_TRUE(reader.has_value()) << "the replaying ioct-rt never created its ring";
  std::vector<std::byte> live(reader->layout().group_payload_bytes);
  std::vector<std::byte> file(recorded.group_bytes());
  std::uint64_t compared = 0;
  std::optional<shm::SlotHeader> first;
  shm::SlotHeader last{};
  const auto end = std::chrono::steady_clock::now() + 60s;
  while (std::chrono::steady_clock::now() < end) {
    const shm::PollStatus poll = reader->read_next(live, header);
    if (poll == shm::PollStatus::producer_gone) break;
    if (poll != shm::PollStatus::ready) {
      std::this_thread::sleep_for(1ms);
      continue;
    }
    const auto it = by_sweep.find(header.first_sweep_counter);
    if (it == by_sweep.end()) break;
    shm::SlotHeader recorded_header{};
    recorded.read_group(it->second, file, recorded_header);
    EXPECT_TRUE(live == file) << "replayed group " << header.group_index << " differs";
    ++compared;
    if (!first) first = header;
    last = header;
    if (it->second + 1 == recorded.group_count()) break;
  }
  replay.send_signal(SIGTERM);
  EXPECT_EQ(exit_code(replay.wait_for(30s)), 0);
  ASSERT_TRUE(first.has_value());
  ASSERT_GE(compared, 10u);
  const double sweeps = static_cast<double>(last.first_sweep_counter - first->first_sweep_counter);
  const double recorded_ns = sweeps * 1e9 / kAscanRateHz;
  const double stamped_ns = static_cast<double>(last.t_first_sweep_ns - first->t_first_sweep_ns);
  const double published_ns = static_cast<double>(last.t_publish_ns - first->t_publish_ns);
  std::printf(
      "[ paced    ] %llu groups: recorded span %.0f ms, stamped %.0f ms, published %.0f "
      "ms (speed %.0f)\n",
      static_cast<unsigned long long>(compared), recorded_ns * 1e-6, stamped_ns * 1e-6,
      published_ns * 1e-6, kSpeed);
  EXPECT_NEAR(stamped_ns, recorded_ns / kSpeed, recorded_ns * 0.001)
      << "the slot stamps do not follow a clock four times the recorded rate";
  EXPECT_LT(published_ns, recorded_ns / 2) << "published no faster than twice real time";
}

TEST(IoctRecord, ReplayOfAnotherGeometryIsRefusedNamingBothValues) {
  const test_support::ScopedShmName ring("record-geometry");
  const test_support::TempPath out("record-geometry", ".h5");
  {
    ChildProcess rt = start("ioct-rt", small_rt(ring.str()));
    ChildProcess recorder = start("ioct-record", record_args(ring.str(), out.path()));
    std::string lines;
    ASSERT_TRUE(wait_for_groups_written(recorder, 2, lines)) << lines;
    recorder.send_signal(SIGTERM);
    ASSERT_EQ(exit_code(recorder.wait_for(30s)), 0);
  }
  std::vector<std::string> arguments = small_rt(ring.str());
  arguments[3] = "512";  // --samples
  arguments.insert(arguments.end(), {"--replay", out.path().string()});
  ChildProcess replay = start("ioct-rt", arguments);
  EXPECT_NE(exit_code(replay.wait_for(30s)), 0);
}

}  // namespace
}  // namespace ioct::ringrec
