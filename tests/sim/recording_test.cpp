// The raw recording format and the replay digitizer: written groups, their status and ground
// truth read back byte for byte with the same metadata; a recording whose writer died keeps its
// whole groups; bad files are refused with a message naming the file and the problem; the replay
// digitizer delivers the recorded groups (looping, or ending with kGroupDeviceLost).
#include <gtest/gtest.h>
#ifdef __SANITIZE_ADDRESS__
#include <sanitizer/lsan_interface.h>
#endif
#include <sys/stat.h>
#include <unistd.h>

#include <bit>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/recording/recording_reader.hpp"
#include "ioct/recording/recording_writer.hpp"
#include "ioct/sim/replay_digitizer.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/sim/simulation_metadata.hpp"
#include "ioct/test_support/bounded_child.hpp"

namespace ioct::sim {
namespace {

namespace fs = std::filesystem;
using recording::RecordingError;
using recording::RecordingReader;
using recording::RecordingWriter;

class Recording : public testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::temp_directory_path() / ("ioct-recording-" + std::to_string(::getpid()) + "-" +
                                     testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    geometry_.samples_per_ascan = 128;
    geometry_.ascans_per_bscan = 24;
    geometry_.flyback_sweeps = 3;
    geometry_.bscans_per_group = 2;
    simulation_.scan.ascans_per_bscan = 24;
    simulation_.scan.bscans_per_volume = 6;
    simulation_.instruments.push_back(
        {InstrumentKind::needle, {0.0f, 0.0f, 0.4f, 90.0f, 20.0f, 0.0f}, {0.5f, 0.0f, 0.0f}});
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  struct Written {
    std::vector<std::vector<std::uint16_t>> groups;
    std::vector<hal::GroupInfo> infos;
    std::vector<GroupTruth> truths;
    recording::RecordingMetadata metadata;
  };

  // Simulates `count` groups (a fault in the middle) and writes them to `stem`.
  Written write(const fs::path& stem, std::uint64_t count, bool close = true) {
    SimulatedDigitizer digitizer(simulation_);
    digitizer.prepare(geometry_);
    digitizer.start();
    Written w;
    w.metadata = recording_metadata(digitizer);
    w.metadata.producer = "recording test";
    auto writer = std::make_unique<RecordingWriter>(stem, w.metadata);
    w.metadata = writer->metadata();  // with its creation time
    for (std::uint64_t g = 0; g < count; ++g) {
      if (g == 1) digitizer.bench().faults().inject_missed_sweeps(5);
      std::vector<std::uint16_t> group(geometry_.samples_per_group());
      hal::GroupInfo info;
      digitizer.acquire_group(group, info);
      writer->append(
          group,
          {0, info.first_sweep_counter, info.missed_sweeps, info.status, 1000 * g, 1000 * g + 999},
          &digitizer.last_group_truth());
      w.groups.push_back(group);
      w.infos.push_back(info);
      w.truths.push_back(digitizer.last_group_truth());
    }
    if (close) {
      writer->close();
    } else {
      // The writer "dies" without closing: its files stay as they are, and so does the object,
      // never destroyed (its destructor would close them); LeakSanitizer is told it is meant.
      [[maybe_unused]] RecordingWriter* const dead = writer.release();
#ifdef __SANITIZE_ADDRESS__
      __lsan_ignore_object(dead);
#endif
    }
    return w;
  }

  fs::path dir_;
  hal::DigitizerConfig geometry_;
  SimulationConfig simulation_;
};

TEST_F(Recording, RoundTripGivesBackTheSameBytesStatusTruthAndMetadata) {
  const fs::path stem = dir_ / "run";
  const Written w = write(stem, 4);
  EXPECT_TRUE(fs::exists(dir_ / "run.json"));
  EXPECT_TRUE(fs::exists(dir_ / "run.raw"));
  EXPECT_TRUE(fs::exists(dir_ / "run.truth"));

  const RecordingReader reader(dir_ / "run.json");
  EXPECT_TRUE(reader.complete());
  EXPECT_EQ(reader.group_count(), 4u);
  EXPECT_EQ(reader.metadata(), w.metadata);
  EXPECT_EQ(reader.metadata().geometry.bscans_per_volume, 6u);
  EXPECT_EQ(reader.metadata().truth_tools, 1u);
  for (std::uint64_t g = 0; g < 4; ++g) {
    std::vector<std::uint16_t> payload(geometry_.samples_per_group());
    recording::RecordedGroupInfo info;
    reader.read_group(g, payload, info);
    EXPECT_EQ(payload, w.groups[g]) << g;
    EXPECT_EQ(info.group_index, g);
    EXPECT_EQ(info.first_sweep_counter, w.infos[g].first_sweep_counter);
    EXPECT_EQ(info.missed_sweeps, w.infos[g].missed_sweeps);
    EXPECT_EQ(info.status, w.infos[g].status);
    EXPECT_EQ(info.first_sweep_ns, 1000 * g);
    GroupTruth truth;
    reader.read_truth(g, truth);
    EXPECT_TRUE(recording::same_bytes(truth, w.truths[g])) << g;
  }
  EXPECT_EQ(w.infos[1].missed_sweeps, 5u) << "the recording carries a fault";
  // The raw file is what the format document says: a 64-byte header, then the samples.
  std::ifstream raw(dir_ / "run.raw", std::ios::binary);
  std::vector<char> bytes(recording::group_stride_bytes(reader.geometry()));
  raw.seekg(static_cast<std::streamoff>(bytes.size()));
  raw.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  EXPECT_EQ(std::memcmp(bytes.data(), "IOCTGRP1", 8), 0);
  std::uint64_t index = 0;
  std::memcpy(&index, bytes.data() + 8, 8);
  EXPECT_EQ(index, 1u);
  EXPECT_EQ(std::memcmp(bytes.data() + 64, w.groups[1].data(), 2 * w.groups[1].size()), 0);
}

TEST_F(Recording, AWriterThatDiedLeavesItsWholeGroupsReadable) {
  const fs::path stem = dir_ / "crashed";
  const Written w = write(stem, 3, false);
  // Half of a fourth record, as a crash in the middle of a write would leave.
  {
    std::ofstream raw(dir_ / "crashed.raw", std::ios::binary | std::ios::app);
    const std::vector<char> half(100, 'x');
    raw.write(half.data(), static_cast<std::streamsize>(half.size()));
  }
  const RecordingReader reader(stem);
  EXPECT_FALSE(reader.complete());
  EXPECT_EQ(reader.group_count(), 3u);
  std::vector<std::uint16_t> payload(geometry_.samples_per_group());
  recording::RecordedGroupInfo info;
  reader.read_group(2, payload, info);
  EXPECT_EQ(payload, w.groups[2]);
}

TEST_F(Recording, ExistingRecordingsAreNotOverwrittenUnlessAsked) {
  const fs::path stem = dir_ / "keep";
  write(stem, 1);
  recording::RecordingMetadata metadata;
  EXPECT_THROW(RecordingWriter(stem, metadata), RecordingError);
  EXPECT_EQ(RecordingReader(stem).group_count(), 1u) << "the old recording is intact";
  EXPECT_NO_THROW(RecordingWriter(stem, metadata, {true}));
  EXPECT_EQ(RecordingReader(stem).group_count(), 0u);
  EXPECT_FALSE(fs::exists(dir_ / "keep.truth")) << "no stale truth beside the new recording";
}

// Expects RecordingReader(stem) to throw a RecordingError whose message contains each of
// `parts`.
void expect_refused(const fs::path& stem, std::initializer_list<std::string> parts) {
  try {
    RecordingReader reader(stem);
    ADD_FAILURE() << "accepted " << stem;
  } catch (const RecordingError& e) {
    const std::string message = e.what();
    for (const std::string& part : parts) {
      EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
    }
  }
}

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

void write_json(const fs::path& path, const nlohmann::json& json) {
  std::ofstream(path) << json.dump(2);
}

TEST_F(Recording, BadFilesGiveClearErrors) {
  const fs::path stem = dir_ / "good";
  write(stem, 2);
  const nlohmann::json good = read_json(dir_ / "good.json");
  const auto variant = [&](const std::string& name, auto change) {
    fs::copy_file(dir_ / "good.raw", dir_ / (name + ".raw"));
    fs::copy_file(dir_ / "good.truth", dir_ / (name + ".truth"));
    nlohmann::json json = good;
    json["raw"]["file"] = name + ".raw";
    json["truth"]["file"] = name + ".truth";
    change(json);
    write_json(dir_ / (name + ".json"), json);
    return dir_ / name;
  };

  expect_refused(dir_ / "absent", {"absent.json", "cannot open"});
  std::ofstream(dir_ / "garbage.json") << "{ not json";
  expect_refused(dir_ / "garbage", {"garbage.json", "not valid JSON"});
  expect_refused(variant("format", [](auto& j) { j["format"] = "hdf5"; }),
                 {"format.json", "format = \"hdf5\"", "not an ioct raw recording"});
  expect_refused(variant("version", [](auto& j) { j["version"] = 7; }),
                 {"version = 7", "reads version 1"});
  expect_refused(variant("missing", [](auto& j) { j["geometry"].erase("samples_per_ascan"); }),
                 {"missing key 'geometry.samples_per_ascan'"});
  expect_refused(variant("odd", [](auto& j) { j["geometry"]["samples_per_ascan"] = 129; }),
                 {"geometry.samples_per_ascan = 129", "even"});
  expect_refused(variant("type", [](auto& j) { j["geometry"]["ascans_per_bscan"] = "24"; }),
                 {"geometry.ascans_per_bscan = \"24\"", "integer"});
  expect_refused(variant("clock", [](auto& j) { j["geometry"]["clock_source"] = "k"; }),
                 {"geometry.clock_source = \"k\""});
  expect_refused(variant("poly",
                         [](auto& j) {
                           j["calibration"]["resampling_coefficients"] = nlohmann::json::array();
                         }),
                 {"calibration.resampling_coefficients", "1 to 8"});
  expect_refused(variant("escape", [](auto& j) { j["raw"]["file"] = "../good.raw"; }),
                 {"raw.file", "beside the metadata"});
  // Geometry that does not match the data file: the record size check names both.
  expect_refused(variant("size", [](auto& j) { j["geometry"]["bscans_per_group"] = 3; }),
                 {"raw.group_stride_bytes"});
  expect_refused(variant("count", [](auto& j) { j["group_count"] = 3; }),
                 {"count.raw", "3 groups", "truncated"});
  // A damaged record header.
  const fs::path damaged = variant("damaged", [](auto&) {});
  {
    std::fstream raw(dir_ / "damaged.raw", std::ios::binary | std::ios::in | std::ios::out);
    raw.seekp(static_cast<std::streamoff>(
        recording::group_stride_bytes(RecordingReader(stem).geometry())));
    raw.write("XXXX", 4);
  }
  const RecordingReader reader(damaged);
  std::vector<std::uint16_t> payload(geometry_.samples_per_group());
  recording::RecordedGroupInfo info;
  EXPECT_NO_THROW(reader.read_group(0, payload, info));
  try {
    reader.read_group(1, payload, info);
    ADD_FAILURE() << "a damaged header was accepted";
  } catch (const RecordingError& e) {
    EXPECT_NE(std::string(e.what()).find("damaged.raw: group 1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad magic"), std::string::npos) << e.what();
  }
  EXPECT_THROW(reader.read_group(2, payload, info), std::out_of_range);
  std::vector<std::uint16_t> short_payload(10);
  EXPECT_THROW(reader.read_group(0, short_payload, info), std::invalid_argument);
}

// Issue F4: group_count x stride is checked for overflow before it is trusted. A count whose
// product wraps to the data file's size (0 for an empty .raw) used to pass, and a reader then
// sized its work by 2^k groups.
TEST_F(Recording, AGroupCountWhoseSizeOverflowsIsRefused) {
  const fs::path stem = dir_ / "good";
  write(stem, 2);
  nlohmann::json json = read_json(dir_ / "good.json");
  const std::uint64_t stride = json["raw"]["group_stride_bytes"].get<std::uint64_t>();
  const int twos = std::countr_zero(stride);
  ASSERT_GT(twos, 0);
  json["group_count"] = std::uint64_t{1} << (64 - twos);  // x stride = 0 mod 2^64
  json["raw"]["file"] = "wrap.raw";
  json["truth"]["file"] = "wrap.truth";
  std::ofstream(dir_ / "wrap.raw");
  std::ofstream(dir_ / "wrap.truth");
  write_json(dir_ / "wrap.json", json);
  expect_refused(dir_ / "wrap", {"wrap.json", "group_count = ", "more than any file holds"});
}

// Issue F6: a FIFO or a device in place of a recording's file is refused at once.
TEST_F(Recording, AFifoOrADeviceInPlaceOfAFileIsRefusedAtOnce) {
  const fs::path stem = dir_ / "good";
  write(stem, 1);
  ASSERT_EQ(::mkfifo((dir_ / "fifo.json").c_str(), 0600), 0);
  const auto outcome = test_support::run_in_child([&] {
    try {
      RecordingReader reader(dir_ / "fifo");
    } catch (const RecordingError& e) {
      return std::string(e.what()).find("a FIFO") != std::string::npos;
    }
    return false;
  });
  EXPECT_EQ(outcome, test_support::ChildOutcome::passed) << to_string(outcome);
  fs::create_symlink("/dev/zero", dir_ / "zero.json");
  expect_refused(dir_ / "zero", {"zero.json", "character device"});
  // The data file as a FIFO.
  nlohmann::json json = read_json(dir_ / "good.json");
  json["raw"]["file"] = "pipe.raw";
  write_json(dir_ / "pipe.json", json);
  ASSERT_EQ(::mkfifo((dir_ / "pipe.raw").c_str(), 0600), 0);
  const auto raw_outcome = test_support::run_in_child([&] {
    try {
      RecordingReader reader(dir_ / "pipe");
    } catch (const RecordingError& e) {
      return std::string(e.what()).find("not a regular file") != std::string::npos;
    }
    return false;
  });
  EXPECT_EQ(raw_outcome, test_support::ChildOutcome::passed) << to_string(raw_outcome);
}

TEST_F(Recording, ReplayDigitizerDeliversTheRecordedGroupsAndLoops) {
  const fs::path stem = dir_ / "replay";
  const Written w = write(stem, 3);
  for (const bool preload : {false, true}) {
    SCOPED_TRACE(preload ? "preloaded" : "streamed");
    ReplayDigitizer replay(stem, {true, preload, nullptr});
    EXPECT_EQ(replay.backend(), "replay");
    replay.prepare(replay.recorded_config());
    replay.start();
    std::vector<std::uint16_t> group(geometry_.samples_per_group());
    const std::uint64_t pass = w.infos[2].first_sweep_counter + geometry_.sweeps_per_group();
    for (std::uint64_t g = 0; g < 7; ++g) {
      hal::GroupInfo info;
      replay.acquire_group(group, info);
      const std::uint64_t k = g % 3;
      EXPECT_EQ(group, w.groups[k]) << g;
      EXPECT_EQ(info.first_sweep_counter, w.infos[k].first_sweep_counter + (g / 3) * pass) << g;
      EXPECT_EQ(info.status, w.infos[k].status) << g;
      EXPECT_EQ(info.missed_sweeps, g == 3 || g == 6 ? 0u : w.infos[k].missed_sweeps) << g;
    }
  }
}

// A recording that spans a producer's restart (its sweep counter starts again at 0) and lost a
// group (a jump forward): the replay's counter never goes back, so the loop does not take the
// restarted part for groups due long ago; the jump is kept, and a new pass follows on without a
// gap.
TEST_F(Recording, ReplayCounterGoesOnThroughARecordedRestartAndKeepsItsGaps) {
  const std::uint64_t spg = geometry_.sweeps_per_group();
  auto groups = std::make_shared<RecordedGroups>();
  groups->metadata.geometry.samples_per_ascan = geometry_.samples_per_ascan;
  groups->metadata.geometry.ascans_per_bscan = geometry_.ascans_per_bscan;
  groups->metadata.geometry.flyback_sweeps = geometry_.flyback_sweeps;
  groups->metadata.geometry.bscans_per_group = geometry_.bscans_per_group;
  groups->metadata.geometry.ascan_rate_hz = geometry_.ascan_rate_hz;
  groups->metadata.geometry.sample_bits = geometry_.sample_bits;
  groups->metadata.geometry.clock_source =
      geometry_.clock_source == hal::ClockSource::internal ? "internal" : "external_k_clock";
  // Recorded: 1000, then a lost group, then the restart at 0 (7 sweeps missed before it), spg.
  const std::uint64_t recorded[4] = {1000, 1000 + 2 * spg, 0, spg};
  groups->samples.assign(4 * geometry_.samples_per_group(), 0);
  for (std::uint64_t g = 0; g < 4; ++g) {
    groups->samples[g * geometry_.samples_per_group()] = static_cast<std::uint16_t>(g + 1);
    groups->infos.push_back({g, recorded[g], g == 2 ? 7u : 0u, 0, 0, 0});
  }
  ReplayDigitizer replay(groups, {.loop = true, .preload = false, .bench = nullptr});
  replay.prepare(geometry_);
  replay.start();
  std::vector<std::uint16_t> group(geometry_.samples_per_group());
  const std::uint64_t expected[6] = {1000,           1000 + 2 * spg, 1000 + 3 * spg,
                                     1000 + 4 * spg, 1000 + 5 * spg, 1000 + 7 * spg};
  for (std::uint64_t g = 0; g < 6; ++g) {
    hal::GroupInfo info;
    replay.acquire_group(group, info);
    EXPECT_EQ(group[0], (g % 4) + 1) << g;
    EXPECT_EQ(info.first_sweep_counter, expected[g]) << "group " << g;
    EXPECT_EQ(info.missed_sweeps, 0u) << "group " << g << ": the restart's own gap is not a loss";
  }
}

TEST_F(Recording, ReplayEndsWithDeviceLostAndRefusesAnotherGeometry) {
  const fs::path stem = dir_ / "once";
  const Written w = write(stem, 2);
  ReplayDigitizer replay(stem, {false, false, nullptr});
  hal::DigitizerConfig other = replay.recorded_config();
  other.samples_per_ascan = 256;
  try {
    replay.prepare(other);
    ADD_FAILURE() << "another geometry was accepted";
  } catch (const ioct::ConfigError& e) {
    EXPECT_EQ(e.key(), "digitizer.samples_per_ascan");
    EXPECT_NE(std::string(e.what()).find("has 128"), std::string::npos) << e.what();
  }
  replay.prepare(replay.recorded_config());
  replay.start();
  std::vector<std::uint16_t> group(geometry_.samples_per_group());
  hal::GroupInfo info;
  replay.acquire_group(group, info);
  replay.acquire_group(group, info);
  EXPECT_FALSE(replay.finished());
  replay.acquire_group(group, info);
  EXPECT_TRUE(replay.finished());
  EXPECT_EQ(info.status, hal::kGroupDeviceLost);
  EXPECT_EQ(info.first_sweep_counter,
            w.infos[1].first_sweep_counter + geometry_.sweeps_per_group());
  replay.stop();
  replay.start();
  replay.acquire_group(group, info);
  EXPECT_EQ(group, w.groups[0]) << "start() plays it again";
}

// A group that cannot be read ends the replay like a lost device, and error() says which. The
// first error outlives a re-arm (start() plays the recording again), but only an arming that
// itself ended at a bad group counts as stopped by it, and arming_error() is that arming's.
TEST_F(Recording, ReplayReadErrorIsKeptAcrossAReArmAndOnlyBlamedForTheArmingItEnded) {
  const fs::path stem = dir_ / "cut";
  const Written w = write(stem, 3);
  ReplayDigitizer replay(stem, {false, false, nullptr});
  replay.prepare(replay.recorded_config());
  // Cut the raw file after its first group while the replay has it open.
  const fs::path raw = recording::recording_paths(stem).raw;
  fs::resize_file(raw, fs::file_size(raw) / 3);
  std::vector<std::uint16_t> group(geometry_.samples_per_group());
  hal::GroupInfo info;
  replay.start();
  replay.acquire_group(group, info);
  EXPECT_EQ(group, w.groups[0]);
  EXPECT_FALSE(replay.stopped_by_error());
  EXPECT_TRUE(replay.error().empty()) << replay.error();
  replay.acquire_group(group, info);
  EXPECT_EQ(info.status, hal::kGroupDeviceLost);
  EXPECT_TRUE(replay.finished());
  EXPECT_TRUE(replay.stopped_by_error());
  const std::string first_error = replay.error();
  EXPECT_NE(first_error.find("cut.raw"), std::string::npos) << first_error;
  EXPECT_NE(first_error.find("truncated while open"), std::string::npos) << first_error;
  EXPECT_EQ(replay.arming_error(), first_error);

  // Re-armed: playing again, the earlier error kept but not this arming's.
  replay.stop();
  replay.start();
  replay.acquire_group(group, info);
  EXPECT_EQ(group, w.groups[0]) << "start() plays it again";
  EXPECT_FALSE(replay.finished());
  EXPECT_FALSE(replay.stopped_by_error()) << "this arming has not met the bad group yet";
  EXPECT_EQ(replay.arming_error(), "");
  EXPECT_EQ(replay.error(), first_error);
  // Re-armed once more with the file cut shorter still: this arming stops at its first group,
  // and says so; the first error is kept.
  replay.stop();
  replay.start();
  fs::resize_file(raw, 1);
  replay.acquire_group(group, info);
  EXPECT_EQ(info.status, hal::kGroupDeviceLost);
  EXPECT_TRUE(replay.stopped_by_error());
  EXPECT_EQ(replay.error(), first_error);
  EXPECT_NE(replay.arming_error(), first_error);
  EXPECT_NE(replay.arming_error().find("cut.raw"), std::string::npos) << replay.arming_error();
}

TEST_F(Recording, PregeneratedGroupsReplayFromMemory) {
  SimulatedDigitizer digitizer(simulation_);
  digitizer.prepare(geometry_);
  digitizer.start();
  const auto groups = RecordedGroups::generate(digitizer, 2);
  ASSERT_EQ(groups->count(), 2u);
  SimulatedDigitizer reference(simulation_);
  reference.prepare(geometry_);
  reference.start();
  ReplayDigitizer replay(groups);
  replay.prepare(geometry_);
  replay.start();
  std::vector<std::uint16_t> expected(geometry_.samples_per_group());
  std::vector<std::uint16_t> got(geometry_.samples_per_group());
  for (int g = 0; g < 2; ++g) {
    hal::GroupInfo a;
    hal::GroupInfo b;
    reference.acquire_group(expected, a);
    replay.acquire_group(got, b);
    EXPECT_EQ(got, expected);
    EXPECT_EQ(b.first_sweep_counter, a.first_sweep_counter);
  }
}

}  // namespace
}  // namespace ioct::sim
