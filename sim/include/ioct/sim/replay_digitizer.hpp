// A digitizer that plays raw groups back instead of recording them: from a recording file -- a
// raw recording (recording_format.hpp) or an HDF5 ring recording (ioct-record, recording/) -- or
// from groups held in memory.
//
// An HDF5 ring recording knows the ring's geometry but not the digitizer's timing (flyback, A-scan
// rate, sample bits, clock source): prepare() checks samples, A-scans and B-scans per group
// against it and takes the rest from the config.
//
// prepare() accepts only the recording's own geometry (ConfigError names the key and the
// recorded value; recorded_config() gives the matching config). Each acquire_group() delivers
// the next recorded group with its recorded status and missed sweeps; the sweep counter keeps
// counting across loops and across a producer's restart inside the recording (the group after
// either follows the one before without a gap), and keeps the recording's forward jumps. At the end
// of a recording without `loop`, acquire_group() reports kGroupDeviceLost (the source is gone) and
// finished() turns true; so does a read error, whose text error() keeps.
//
// Streaming from a file reads each group with pread() into the slot (one copy, a system call per
// group); preloaded or in-memory groups are copied from memory. The throughput mode is
// in-memory groups with no pacing: they go into the ring as fast as it takes them.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ioct/hal/digitizer.hpp"
#include "ioct/recording/recording_format.hpp"
#include "ioct/recording/recording_reader.hpp"
#include "ioct/ringrec/ring_recording_reader.hpp"

namespace ioct::sim {

class SimulatedBench;
class SimulatedDigitizer;

// Groups held in memory, with what the acquisition said about each.
struct RecordedGroups {
  recording::RecordingMetadata metadata;
  std::vector<std::uint16_t> samples;  // group after group
  std::vector<recording::RecordedGroupInfo> infos;

  std::uint64_t count() const noexcept { return infos.size(); }
  std::span<const std::uint16_t> group(std::uint64_t index) const noexcept;

  // Reads every group of a recording (at most `max_groups`).
  static std::shared_ptr<const RecordedGroups> load(const recording::RecordingReader& reader,
                                                    std::uint64_t max_groups = UINT64_MAX);
  // Generates `count` groups with a prepared, started simulated digitizer (the throughput mode's
  // pre-generated groups).
  static std::shared_ptr<const RecordedGroups> generate(SimulatedDigitizer& digitizer,
                                                        std::uint64_t count);
};

struct ReplayOptions {
  bool loop = true;      // start again after the last group
  bool preload = false;  // read a raw recording into memory when constructed (not HDF5)
  // The bench of a simulated galvo output (ioct-rt --replay): each group clocks the output's
  // samples out, as the hardware's sweep trigger would; without it the mirrors never move and
  // the acquisition is never verified. Null: no galvo output to clock.
  std::shared_ptr<SimulatedBench> bench;
};

// The digitizer config a recording was made with.
hal::DigitizerConfig digitizer_config(const recording::RecordingGeometry& geometry);

class ReplayDigitizer final : public hal::Digitizer {
 public:
  // Plays a recording file: an HDF5 ring recording when the file is HDF5, else a raw recording.
  // Throws recording::RecordingError or ringrec::RingRecordingError for a bad recording.
  explicit ReplayDigitizer(const std::filesystem::path& recording, ReplayOptions options = {});
  // Plays groups held in memory.
  explicit ReplayDigitizer(std::shared_ptr<const RecordedGroups> groups,
                           ReplayOptions options = {});
  ~ReplayDigitizer() override;

  std::string_view backend() const noexcept override { return "replay"; }
  const recording::RecordingMetadata& metadata() const noexcept;
  hal::DigitizerConfig recorded_config() const { return digitizer_config(metadata().geometry); }
  std::uint64_t group_count() const noexcept;
  bool finished() const noexcept { return finished_; }
  // The first group it could not read, and why; kept across start() (a re-arm plays the
  // recording again, and the reason must still be there when the process reports it). Written
  // once by the acquiring thread and never changed after: any thread may read it once
  // has_error() is true (the live status does, while the acquisition runs).
  bool has_error() const noexcept { return has_error_.load(std::memory_order_acquire); }
  const std::string& error() const noexcept { return error_; }
  // Whether the replay since the last start() ended at a group it could not read; false while
  // it plays and after an end of the recording, so an earlier failure is not taken for the cause
  // of a later stop.
  bool stopped_by_error() const noexcept {
    return stopped_by_error_.load(std::memory_order_acquire);
  }
  // Which group, and why, when stopped_by_error(); empty otherwise. A copy, from any thread.
  std::string arming_error() const;

 protected:
  void do_prepare(const hal::DigitizerConfig& config) override;
  void do_start() override;
  void do_stop() noexcept override {}
  void do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) override;

 private:
  void read_ring_info(std::uint64_t index, recording::RecordedGroupInfo& info) const;

  std::optional<recording::RecordingReader> reader_;
  std::optional<ringrec::RingRecordingReader> ring_reader_;  // an HDF5 ring recording
  recording::RecordingMetadata ring_metadata_;               // what it says, the rest from prepare
  std::shared_ptr<const RecordedGroups> memory_;
  ReplayOptions options_;
  std::string source_;
  std::uint64_t next_ = 0;
  std::uint64_t loops_ = 0;
  std::uint64_t next_counter_ = 0;  // the counter a contiguous next group would start at
  std::uint64_t first_counter_ = 0;
  std::uint64_t counter_offset_ = 0;  // added to the recorded counters (see do_acquire_group)
  bool finished_ = false;
  std::atomic<bool> stopped_by_error_{false};
  std::atomic<bool> has_error_{false};
  std::string error_;  // set once, before has_error_
  // This arming's error. Locked only where an arming starts and where a group could not be read
  // (the arming ends there), never while groups play.
  mutable std::mutex arming_error_mutex_;
  std::string arming_error_;
};

}  // namespace ioct::sim
