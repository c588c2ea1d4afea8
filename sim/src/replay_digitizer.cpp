#include "ioct/sim/replay_digitizer.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "ioct/common/config_error.hpp"
#include "ioct/sim/simulated_bench.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/sim/simulation_metadata.hpp"

namespace ioct::sim {
namespace {

bool is_hdf5(const std::filesystem::path& path) {
  static constexpr char kSignature[8] = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  char head[8] = {};
  in.read(head, sizeof head);
  return in.gcount() == sizeof head && std::memcmp(head, kSignature, sizeof head) == 0;
}

// The ring's status flags as the digitizer's (hal/digitizer.hpp) where they mean the same.
std::uint32_t digitizer_status(std::uint32_t ring_flags) {
  std::uint32_t status = 0;
  if (ring_flags & shm::kStatusOverrun) status |= hal::kGroupOverrun;
  if (ring_flags & shm::kStatusClockFault) status |= hal::kGroupClockFault;
  if (ring_flags & shm::kStatusMissedTriggers) status |= hal::kGroupMissedTriggers;
  return status;
}

}  // namespace

std::span<const std::uint16_t> RecordedGroups::group(std::uint64_t index) const noexcept {
  const std::uint64_t words = metadata.geometry.samples_per_group();
  return {samples.data() + index * words, static_cast<std::size_t>(words)};
}

std::shared_ptr<const RecordedGroups> RecordedGroups::load(const recording::RecordingReader& reader,
                                                           std::uint64_t max_groups) {
  auto groups = std::make_shared<RecordedGroups>();
  groups->metadata = reader.metadata();
  const std::uint64_t count = std::min(reader.group_count(), max_groups);
  const std::uint64_t words = reader.geometry().samples_per_group();
  groups->samples.resize(count * words);
  groups->infos.resize(count);
  for (std::uint64_t g = 0; g < count; ++g) {
    reader.read_group(g, std::span<std::uint16_t>(groups->samples.data() + g * words, words),
                      groups->infos[g]);
  }
  return groups;
}

std::shared_ptr<const RecordedGroups> RecordedGroups::generate(SimulatedDigitizer& digitizer,
                                                               std::uint64_t count) {
  auto groups = std::make_shared<RecordedGroups>();
  groups->metadata = recording_metadata(digitizer);
  groups->metadata.has_truth = false;  // groups only
  groups->metadata.truth_tools = 0;
  const std::uint64_t words = digitizer.config().samples_per_group();
  groups->samples.resize(count * words);
  groups->infos.resize(count);
  for (std::uint64_t g = 0; g < count; ++g) {
    hal::GroupInfo info;
    digitizer.acquire_group(std::span<std::uint16_t>(groups->samples.data() + g * words, words),
                            info);
    groups->infos[g] = {g, info.first_sweep_counter, info.missed_sweeps, info.status, 0, 0};
  }
  return groups;
}

hal::DigitizerConfig digitizer_config(const recording::RecordingGeometry& g) {
  hal::DigitizerConfig config;
  config.samples_per_ascan = g.samples_per_ascan;
  config.ascans_per_bscan = g.ascans_per_bscan;
  config.flyback_sweeps = g.flyback_sweeps;
  config.bscans_per_group = g.bscans_per_group;
  config.ascan_rate_hz = g.ascan_rate_hz;
  config.sample_bits = g.sample_bits;
  config.clock_source = g.clock_source == "internal" ? hal::ClockSource::internal
                                                     : hal::ClockSource::external_k_clock;
  return config;
}

ReplayDigitizer::ReplayDigitizer(const std::filesystem::path& recording, ReplayOptions options)
    : options_(options) {
  if (is_hdf5(recording)) {
    ring_reader_.emplace(recording);
    source_ = recording.string();
    const shm::RingGeometry& g = ring_reader_->geometry();
    if (g.bytes_per_sample != 2) {
      throw ringrec::RingRecordingError(source_ + ": samples of " +
                                        std::to_string(g.bytes_per_sample) +
                                        " bytes; the digitizer delivers 16-bit samples");
    }
    ring_metadata_.geometry.samples_per_ascan = g.samples_per_ascan;
    ring_metadata_.geometry.ascans_per_bscan = g.ascans_per_bscan;
    ring_metadata_.geometry.bscans_per_group = g.bscans_per_group;
    ring_metadata_.geometry.bscans_per_volume = g.bscans_per_volume;
    ring_metadata_.producer = "ring recording " + source_;
    return;
  }
  reader_.emplace(recording);
  source_ = reader_->json_path().string();
  if (options_.preload) {
    memory_ = RecordedGroups::load(*reader_);
    reader_.reset();
  }
}

ReplayDigitizer::ReplayDigitizer(std::shared_ptr<const RecordedGroups> groups,
                                 ReplayOptions options)
    : memory_(std::move(groups)), options_(options), source_("groups in memory") {
  if (!memory_) throw std::invalid_argument("replay digitizer: no groups");
}

ReplayDigitizer::~ReplayDigitizer() = default;

const recording::RecordingMetadata& ReplayDigitizer::metadata() const noexcept {
  if (memory_) return memory_->metadata;
  return ring_reader_ ? ring_metadata_ : reader_->metadata();
}

std::uint64_t ReplayDigitizer::group_count() const noexcept {
  if (memory_) return memory_->count();
  return ring_reader_ ? ring_reader_->group_count() : reader_->group_count();
}

void ReplayDigitizer::read_ring_info(std::uint64_t index,
                                     recording::RecordedGroupInfo& info) const {
  shm::SlotHeader header{};
  ring_reader_->read_header(index, header);
  info = {index,
          header.first_sweep_counter,
          header.missed_sweeps,
          digitizer_status(header.status_flags),
          header.t_first_sweep_ns,
          header.t_last_sweep_ns};
}

void ReplayDigitizer::do_prepare(const hal::DigitizerConfig& config) {
  if (ring_reader_) {
    // What the ring recording does not know comes from the config; the rest must agree.
    recording::RecordingMetadata& m = ring_metadata_;
    m.geometry.flyback_sweeps = config.flyback_sweeps;
    m.geometry.ascan_rate_hz = config.ascan_rate_hz;
    m.geometry.sample_bits = config.sample_bits;
    m.geometry.clock_source =
        config.clock_source == hal::ClockSource::internal ? "internal" : "external_k_clock";
  }
  const hal::DigitizerConfig recorded = recorded_config();
  const auto require = [&](const char* key, auto given, auto expected) {
    if (given != expected) {
      throw ioct::ConfigError(std::string("digitizer.") + key, ioct::format_value(given),
                              "the recording " + source_ + " has " + ioct::format_value(expected));
    }
  };
  require("samples_per_ascan", std::uint64_t{config.samples_per_ascan},
          std::uint64_t{recorded.samples_per_ascan});
  require("ascans_per_bscan", std::uint64_t{config.ascans_per_bscan},
          std::uint64_t{recorded.ascans_per_bscan});
  require("flyback_sweeps", std::uint64_t{config.flyback_sweeps},
          std::uint64_t{recorded.flyback_sweeps});
  require("bscans_per_group", std::uint64_t{config.bscans_per_group},
          std::uint64_t{recorded.bscans_per_group});
  require("sample_bits", std::uint64_t{config.sample_bits}, std::uint64_t{recorded.sample_bits});
  require("ascan_rate_hz", config.ascan_rate_hz, recorded.ascan_rate_hz);
  if (config.clock_source != recorded.clock_source) {
    throw ioct::ConfigError(
        "digitizer.clock_source", std::string(to_string(config.clock_source)),
        "the recording " + source_ + " has " + std::string(to_string(recorded.clock_source)));
  }
  if (group_count() == 0) {
    throw recording::RecordingError(source_ + ": the recording holds no group to replay");
  }
  recording::RecordedGroupInfo first;
  if (memory_) {
    first = memory_->infos.front();
  } else if (ring_reader_) {
    read_ring_info(0, first);
  } else {
    reader_->read_info(0, first);
  }
  if (options_.bench) {
    options_.bench->scanner().set_dynamics(options_.bench->config().mirrors, config.ascan_rate_hz);
  }
  first_counter_ = first.first_sweep_counter;
}

std::string ReplayDigitizer::arming_error() const {
  std::lock_guard lock(arming_error_mutex_);
  return arming_error_;
}

void ReplayDigitizer::do_start() {
  next_ = 0;
  loops_ = 0;
  finished_ = false;
  {
    std::lock_guard lock(arming_error_mutex_);
    arming_error_.clear();
  }
  stopped_by_error_.store(false, std::memory_order_release);
  next_counter_ = first_counter_;
  counter_offset_ = 0;
}

void ReplayDigitizer::do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) {
  if (!finished_ && next_ == group_count()) {
    if (options_.loop) {
      next_ = 0;
      ++loops_;
    } else {
      finished_ = true;
    }
  }
  if (finished_) {
    info = {next_counter_, 0, hal::kGroupDeviceLost};
    return;
  }
  recording::RecordedGroupInfo recorded;
  if (memory_) {
    const std::span<const std::uint16_t> source = memory_->group(next_);
    std::memcpy(group.data(), source.data(), source.size_bytes());
    recorded = memory_->infos[next_];
  } else {
    try {
      if (ring_reader_) {
        shm::SlotHeader header{};
        ring_reader_->read_group(next_, std::as_writable_bytes(group), header);
        recorded = {next_,
                    header.first_sweep_counter,
                    header.missed_sweeps,
                    digitizer_status(header.status_flags),
                    header.t_first_sweep_ns,
                    header.t_last_sweep_ns};
      } else {
        reader_->read_group(next_, group, recorded);
      }
    } catch (const std::exception& e) {
      if (!has_error_.load(std::memory_order_relaxed)) {
        error_ = e.what();
        has_error_.store(true, std::memory_order_release);
      }
      {
        std::lock_guard lock(arming_error_mutex_);
        arming_error_ = e.what();
      }
      stopped_by_error_.store(true, std::memory_order_release);
      finished_ = true;
      info = {next_counter_, 0, hal::kGroupDeviceLost};
      return;
    }
  }
  // The sweep counter only goes forward. Where the recording's goes back -- a new pass of a
  // looped replay, or a producer that restarted while it was recorded (its counter starts again)
  // -- the group follows the one before without a gap, and the rest of the recording with it;
  // otherwise the loop would take it for a group due long ago (a deadline miss). A jump forward
  // (groups the recorder lost) is kept: the replay leaves their time out as the recording did.
  std::uint64_t counter = recorded.first_sweep_counter + counter_offset_;
  std::uint32_t missed = recorded.missed_sweeps;
  if (counter < next_counter_ || (next_ == 0 && loops_ > 0)) {
    counter_offset_ = next_counter_ - recorded.first_sweep_counter;
    counter = next_counter_;
    missed = 0;
  }
  info.first_sweep_counter = counter;
  info.missed_sweeps = missed;
  info.status = recorded.status;
  next_counter_ = info.first_sweep_counter + metadata().geometry.sweeps_per_group();
  if (options_.bench && options_.bench->galvo_attached()) {
    // The group's sweeps (and those lost before it) trigger the galvo output's samples.
    options_.bench->scanner().advance(metadata().geometry.sweeps_per_group() + info.missed_sweeps,
                                      true, nullptr);
  }
  ++next_;
}

}  // namespace ioct::sim
