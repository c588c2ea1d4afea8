// The laser-safety state machine, as pure code: each step takes what the lines, the acquisition
// thread and the operator report, and says whether the emission line is driven, whether the
// acquisition runs or parks the galvos, and whether the external watchdog may be fed.
//
//   idle ──start──▶ arming ──verified + read-back on──▶ scanning
//                     │                                   │
//                     └────────── any fault ──────────────┤──stop──▶ stopping ──off + parked──▶
//                     idle
//                                                         ▼
//                      safe ◀──emission off read back + galvos parked── fault
//                        └──start (re-arm, causes cleared) or auto re-arm──▶ arming
//
// Emission is driven only in arming (once the acquisition is verified) and in scanning. Every
// fault drops it in the same step and commands the park; the machine leaves `fault` only when the
// read-back shows emission off and the acquisition reports the galvos parked. If the read-back
// still shows emission on after readback_timeout, it stops feeding the external watchdog, which
// then cuts the laser in hardware.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "ioct/hal/lines.hpp"

namespace ioct::rt {

enum class SafetyState : std::uint8_t { idle, arming, scanning, stopping, fault, safe };
std::string_view to_string(SafetyState state) noexcept;

// Fault causes (bits); the acquisition thread posts the first nine, the machine finds the rest.
inline constexpr std::uint32_t kFaultDigitizerTimeout = 1u << 0;    // no record for timeout_ms
inline constexpr std::uint32_t kFaultDigitizerLost = 1u << 1;       // the digitizer went away
inline constexpr std::uint32_t kFaultClockLost = 1u << 2;           // k-clock lost (group or line)
inline constexpr std::uint32_t kFaultTriggerLost = 1u << 3;         // sweep triggers missing
inline constexpr std::uint32_t kFaultGalvoUnderrun = 1u << 4;       // the DAC FIFO ran dry
inline constexpr std::uint32_t kFaultGalvoFault = 1u << 5;          // driver fault, device lost
inline constexpr std::uint32_t kFaultDeadlineMisses = 1u << 6;      // too many misses in a row
inline constexpr std::uint32_t kFaultAcquisitionFailed = 1u << 7;   // an error ended acquisition
inline constexpr std::uint32_t kFaultStartFailed = 1u << 8;         // galvo/digitizer start threw
inline constexpr std::uint32_t kFaultAcquisitionStalled = 1u << 9;  // its heartbeat stopped
inline constexpr std::uint32_t kFaultLaserNotReady = 1u << 10;      // laser_ready input low
inline constexpr std::uint32_t kFaultEmissionReadback = 1u << 11;   // read-back != commanded
inline constexpr std::uint32_t kFaultArmingTimeout = 1u << 12;      // never verified
inline constexpr std::uint32_t kFaultFootswitch = 1u << 13;         // footswitch released

// "digitizer_timeout,k_clock_lost" for logs and status; "none" for 0.
std::string describe_faults(std::uint32_t faults);

struct SafetyPolicy {
  std::uint64_t arming_timeout_ns = 2'000'000'000;  // start → verified and emitting
  std::uint64_t readback_timeout_ns = 10'000'000;   // emission line command → read-back
  std::uint64_t stall_timeout_ns = 1'000'000'000;   // acquisition heartbeat age that is a stall
  bool monitor_laser_ready = true;                  // fault when the laser_ready input drops
  bool monitor_k_clock = true;                      // ... k_clock_valid
  bool monitor_sweep_trigger = true;                // ... sweep_trigger_present
  bool require_footswitch = false;                  // emit only while the footswitch is pressed
  std::uint64_t auto_rearm_delay_ns = 0;            // 0: re-arm only on a start command
};

// What one step sees.
struct SafetyInputs {
  std::uint64_t now_ns = 0;  // CLOCK_MONOTONIC
  hal::LineInputs lines;
  bool emission_readback = false;
  // From the acquisition thread.
  bool acquisition_streaming = false;  // galvo and digitizer running (not parked)
  bool acquisition_verified = false;   // a good group since arming, galvo clocking out
  std::uint32_t acquisition_faults = 0;
  std::uint64_t acquisition_heartbeat_ns = 0;
  // From the operator (control channel, signals), one step each.
  bool start_requested = false;
  bool stop_requested = false;
};

enum class LoopCommand : std::uint8_t { park, run };

// What one step says to do.
struct SafetyOutputs {
  bool emission = false;
  LoopCommand loop = LoopCommand::park;
  bool feed_watchdog = true;
};

// The times the status and the tests check bounds against (CLOCK_MONOTONIC ns, 0 = not yet).
struct SafetyRecord {
  std::uint64_t state_entered_ns = 0;
  std::uint64_t fault_ns = 0;            // when the last fault (or stop) was taken
  std::uint32_t faults = 0;              // causes latched since then
  std::uint64_t emission_off_ns = 0;     // first read-back of emission off after it
  std::uint64_t parked_ns = 0;           // first report of the galvos parked after it
  std::uint64_t emission_on_ns = 0;      // last time emission was verified on
  bool emission_off_unverified = false;  // read-back still on past readback_timeout
  std::uint64_t faults_total = 0;        // faults taken since construction
  std::uint64_t arms_total = 0;          // times arming was entered
};

class SafetyStateMachine {
 public:
  explicit SafetyStateMachine(SafetyPolicy policy) noexcept : policy_(policy) {}

  SafetyOutputs step(const SafetyInputs& in) noexcept;

  SafetyState state() const noexcept { return state_; }
  const SafetyRecord& record() const noexcept { return record_; }
  const SafetyPolicy& policy() const noexcept { return policy_; }
  // Why the last start request was refused (static text), empty when it was not.
  std::string_view refusal() const noexcept { return refusal_; }
  // Faults the inputs show right now under the policy (laser not ready, k-clock, trigger, ...).
  std::uint32_t line_faults(const hal::LineInputs& lines) const noexcept;

 private:
  SafetyOutputs arm(const SafetyInputs& in, std::uint32_t from_lines) noexcept;
  SafetyOutputs step_arming(const SafetyInputs& in, std::uint32_t from_lines) noexcept;
  // stopping and fault: emission off, galvos parked, until both are confirmed.
  SafetyOutputs settle(const SafetyInputs& in) noexcept;
  void enter(SafetyState state, std::uint64_t now_ns) noexcept;
  void take_fault(std::uint32_t faults, std::uint64_t now_ns, SafetyState next) noexcept;
  SafetyOutputs outputs(bool emission, LoopCommand loop) const noexcept;

  SafetyPolicy policy_;
  SafetyState state_ = SafetyState::idle;
  SafetyRecord record_;
  bool emission_commanded_ = false;
  std::uint64_t emission_commanded_ns_ = 0;
  bool counting_confirmations_ = true;
  std::string_view refusal_;
};

}  // namespace ioct::rt
