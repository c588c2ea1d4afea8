#include "safety_state_machine.hpp"

#include <array>
#include <utility>

namespace ioct::rt {
namespace {

constexpr std::array<std::pair<std::uint32_t, const char*>, 14> kFaultNames{{
    {kFaultDigitizerTimeout, "digitizer_timeout"},
    {kFaultDigitizerLost, "digitizer_lost"},
    {kFaultClockLost, "k_clock_lost"},
    {kFaultTriggerLost, "trigger_lost"},
    {kFaultGalvoUnderrun, "galvo_underrun"},
    {kFaultGalvoFault, "galvo_fault"},
    {kFaultDeadlineMisses, "deadline_misses"},
    {kFaultAcquisitionFailed, "acquisition_failed"},
    {kFaultStartFailed, "start_failed"},
    {kFaultAcquisitionStalled, "acquisition_stalled"},
    {kFaultLaserNotReady, "laser_not_ready"},
    {kFaultEmissionReadback, "emission_readback"},
    {kFaultArmingTimeout, "arming_timeout"},
    {kFaultFootswitch, "footswitch_released"},
}};

std::uint64_t age(std::uint64_t now, std::uint64_t since) noexcept {
  return now > since ? now - since : 0;
}

}  // namespace

std::string_view to_string(SafetyState state) noexcept {
  switch (state) {
    case SafetyState::idle:
      return "idle";
    case SafetyState::arming:
      return "arming";
    case SafetyState::scanning:
      return "scanning";
    case SafetyState::stopping:
      return "stopping";
    case SafetyState::fault:
      return "fault";
    case SafetyState::safe:
      return "safe";
  }
  return "unknown";
}

std::string describe_faults(std::uint32_t faults) {
  if (faults == 0) return "none";
  std::string text;
  for (const auto& [bit, name] : kFaultNames) {
    if ((faults & bit) == 0) continue;
    if (!text.empty()) text += ',';
    text += name;
    faults &= ~bit;
  }
  if (faults != 0) text += (text.empty() ? "" : ",") + std::string("unknown");
  return text;
}

std::uint32_t SafetyStateMachine::line_faults(const hal::LineInputs& lines) const noexcept {
  std::uint32_t faults = 0;
  if (policy_.monitor_laser_ready && !lines.laser_ready) faults |= kFaultLaserNotReady;
  if (policy_.monitor_k_clock && !lines.k_clock_valid) faults |= kFaultClockLost;
  if (policy_.monitor_sweep_trigger && !lines.sweep_trigger_present) faults |= kFaultTriggerLost;
  if (policy_.require_footswitch && !lines.footswitch) faults |= kFaultFootswitch;
  return faults;
}

void SafetyStateMachine::enter(SafetyState state, std::uint64_t now_ns) noexcept {
  state_ = state;
  record_.state_entered_ns = now_ns;
}

void SafetyStateMachine::take_fault(std::uint32_t faults, std::uint64_t now_ns,
                                    SafetyState next) noexcept {
  record_.fault_ns = now_ns;
  record_.faults = faults;
  record_.emission_off_ns = 0;
  record_.parked_ns = 0;
  record_.emission_off_unverified = false;
  if (next == SafetyState::fault) ++record_.faults_total;
  emission_commanded_ = false;
  emission_commanded_ns_ = now_ns;
  counting_confirmations_ = false;
  enter(next, now_ns);
}

SafetyOutputs SafetyStateMachine::outputs(bool emission, LoopCommand loop) const noexcept {
  return {emission, loop, !record_.emission_off_unverified};
}

SafetyOutputs SafetyStateMachine::step(const SafetyInputs& in) noexcept {
  refusal_ = {};
  const std::uint64_t now = in.now_ns;
  const std::uint32_t from_lines = line_faults(in.lines);

  switch (state_) {
    case SafetyState::idle:
      if (in.emission_readback) {  // emitting although nothing commands it: a stuck line
        take_fault(kFaultEmissionReadback, now, SafetyState::fault);
        return settle(in);
      }
      if (in.start_requested) return arm(in, from_lines);
      return outputs(false, LoopCommand::park);

    case SafetyState::arming:
      return step_arming(in, from_lines);

    case SafetyState::scanning: {
      std::uint32_t faults = in.acquisition_faults | from_lines;
      if (!in.emission_readback) faults |= kFaultEmissionReadback;
      if (age(now, in.acquisition_heartbeat_ns) > policy_.stall_timeout_ns) {
        faults |= kFaultAcquisitionStalled;
      }
      if (faults != 0) {
        take_fault(faults, now, SafetyState::fault);
        return settle(in);
      }
      if (in.stop_requested) {
        take_fault(0, now, SafetyState::stopping);
        return settle(in);
      }
      record_.emission_on_ns = now;
      return outputs(true, LoopCommand::run);
    }

    case SafetyState::stopping:
    case SafetyState::fault:
      if (in.start_requested) refusal_ = "a stop or a fault is still being handled";
      return settle(in);

    case SafetyState::safe: {
      if (in.emission_readback) {
        take_fault(record_.faults | kFaultEmissionReadback, now, SafetyState::fault);
        return settle(in);
      }
      if (in.stop_requested) {
        record_.faults = 0;
        enter(SafetyState::idle, now);
        return outputs(false, LoopCommand::park);
      }
      const bool rearm_due = policy_.auto_rearm_delay_ns != 0 &&
                             age(now, record_.state_entered_ns) >= policy_.auto_rearm_delay_ns;
      if (in.start_requested || rearm_due) {
        if (from_lines == 0) return arm(in, from_lines);
        if (in.start_requested) {
          refusal_ =
              "cannot re-arm while the laser-ready, k-clock, trigger or footswitch inputs "
              "show a fault";
        }
      }
      return outputs(false, LoopCommand::park);
    }
  }
  return outputs(false, LoopCommand::park);
}

SafetyOutputs SafetyStateMachine::arm(const SafetyInputs& in, std::uint32_t from_lines) noexcept {
  ++record_.arms_total;
  record_.faults = 0;
  emission_commanded_ = false;
  enter(SafetyState::arming, in.now_ns);
  return step_arming(in, from_lines);
}

SafetyOutputs SafetyStateMachine::step_arming(const SafetyInputs& in,
                                              std::uint32_t from_lines) noexcept {
  const std::uint64_t now = in.now_ns;
  std::uint32_t faults = in.acquisition_faults | from_lines;
  if (in.emission_readback && !emission_commanded_) faults |= kFaultEmissionReadback;
  if (emission_commanded_ && !in.emission_readback &&
      age(now, emission_commanded_ns_) > policy_.readback_timeout_ns) {
    faults |= kFaultEmissionReadback;
  }
  if (age(now, record_.state_entered_ns) > policy_.arming_timeout_ns) {
    faults |= kFaultArmingTimeout;
  }
  if (faults != 0) {
    take_fault(faults, now, SafetyState::fault);
    return settle(in);
  }
  if (in.stop_requested) {
    take_fault(0, now, SafetyState::stopping);
    return settle(in);
  }
  if (!in.acquisition_verified) return outputs(false, LoopCommand::run);
  if (!emission_commanded_) {
    emission_commanded_ = true;
    emission_commanded_ns_ = now;
  }
  if (in.emission_readback) {
    record_.emission_on_ns = now;
    enter(SafetyState::scanning, now);
  }
  return outputs(true, LoopCommand::run);
}

SafetyOutputs SafetyStateMachine::settle(const SafetyInputs& in) noexcept {
  const std::uint64_t now = in.now_ns;
  // Causes the acquisition finds while parking join the latched ones.
  if (state_ == SafetyState::fault) record_.faults |= in.acquisition_faults;
  // What the step that took the fault saw predates the off and park commands it gave: only later
  // read-backs and reports confirm them.
  if (!counting_confirmations_) {
    counting_confirmations_ = true;
    return outputs(false, LoopCommand::park);
  }
  if (!in.emission_readback && record_.emission_off_ns == 0) record_.emission_off_ns = now;
  if (!in.acquisition_streaming && record_.parked_ns == 0) record_.parked_ns = now;
  if (in.emission_readback && age(now, record_.fault_ns) > policy_.readback_timeout_ns) {
    record_.emission_off_unverified = true;  // stop feeding the external watchdog
  }
  if (!in.emission_readback && record_.emission_off_ns != 0 && record_.parked_ns != 0) {
    record_.emission_off_unverified = false;
    enter(state_ == SafetyState::stopping ? SafetyState::idle : SafetyState::safe, now);
  }
  return outputs(false, LoopCommand::park);
}

}  // namespace ioct::rt
