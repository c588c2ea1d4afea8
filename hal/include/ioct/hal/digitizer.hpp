// The digitizer interface: records groups of raw spectra straight into memory the caller owns.
//
// The caller hands acquire_group() the payload of a ring slot, so a group goes from the ADC (or
// the simulator) to the readers without a copy. Backends allocate everything in prepare(); from
// start() to stop() acquire_group() neither allocates, locks nor logs.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "ioct/hal/digitizer_config.hpp"

namespace ioct::hal {

// GroupInfo::status flags: what went wrong while the group was recorded.
inline constexpr std::uint32_t kGroupOverrun = 1u << 0;         // the on-board buffer overflowed
inline constexpr std::uint32_t kGroupClockFault = 1u << 1;      // the k-clock was lost or off
inline constexpr std::uint32_t kGroupMissedTriggers = 1u << 2;  // sweep triggers went missing
inline constexpr std::uint32_t kGroupTimeout = 1u << 3;         // no record for timeout_ms: a stall
inline constexpr std::uint32_t kGroupDeviceLost = 1u << 4;      // the device went away (unplugged)
// The group is whole but came after its last sweep had ended because its source fell behind
// (the simulator's synthesis workers); the caller did not miss its deadline by itself.
inline constexpr std::uint32_t kGroupLate = 1u << 5;

struct GroupInfo {
  std::uint64_t first_sweep_counter = 0;  // hardware sweep counter of the group's first record
  std::uint32_t missed_sweeps = 0;        // sweeps lost between the previous group and this one
  std::uint32_t status = 0;               // kGroup* flags
};

class Digitizer {
 public:
  enum class State { idle, prepared, running };

  Digitizer() = default;
  Digitizer(const Digitizer&) = delete;
  Digitizer& operator=(const Digitizer&) = delete;
  virtual ~Digitizer() = default;

  // Validates `config` (ConfigError names the key) and allocates what acquisition needs. Only
  // while not running; throws std::logic_error otherwise.
  void prepare(const DigitizerConfig& config);
  // Starts recording; the sweep counter starts at 0. Requires prepare().
  void start();
  // Stops recording; harmless when not running.
  void stop() noexcept;

  // Fills the first config().samples_per_group() words of `slot_payload` with the next group,
  // layout [bscan][ascan][sample], samples contiguous, values in [0, 2^sample_bits) right-aligned
  // in 16-bit words, and describes it in `info`. Blocks until the group is complete where the
  // hardware paces it. Problems of the acquisition are reported in info.status, never thrown;
  // std::logic_error is thrown only for misuse (not running, payload too small).
  void acquire_group(std::span<std::uint16_t> slot_payload, GroupInfo& info);

  const DigitizerConfig& config() const noexcept { return config_; }
  State state() const noexcept { return state_; }
  // Short name of the backend for logs, e.g. "simulated".
  virtual std::string_view backend() const noexcept = 0;

 protected:
  virtual void do_prepare(const DigitizerConfig& config) = 0;
  virtual void do_start() = 0;
  virtual void do_stop() noexcept = 0;
  virtual void do_acquire_group(std::span<std::uint16_t> group, GroupInfo& info) = 0;

 private:
  DigitizerConfig config_;
  State state_ = State::idle;
};

}  // namespace ioct::hal
