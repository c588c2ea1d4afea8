// The safety state machine, step by step in logical time: every transition, that a fault drops
// emission and commands the park in the very step it is seen, that leaving `fault` waits for
// the read-back and the park, the watchdog when emission will not go off, and re-arming.
#include "safety_state_machine.hpp"

#include <gtest/gtest.h>

#include <string>

namespace ioct::rt {
namespace {

constexpr std::uint64_t kMs = 1'000'000;

SafetyPolicy policy() {
  SafetyPolicy p;
  p.arming_timeout_ns = 100 * kMs;
  p.readback_timeout_ns = 10 * kMs;
  p.stall_timeout_ns = 50 * kMs;
  return p;
}

// Drives a machine as the safety thread does, with a world that follows its outputs unless told
// otherwise: the emission line reads back what was driven, the acquisition streams while told to
// run and reports itself verified once streaming.
class Bench {
 public:
  explicit Bench(SafetyPolicy p = policy()) : machine(p) {}

  SafetyOutputs step() {
    in.now_ns = now;
    in.acquisition_heartbeat_ns = now;
    const SafetyOutputs out = machine.step(in);
    last = out;
    in.start_requested = false;
    in.stop_requested = false;
    if (follow_emission) in.emission_readback = out.emission;
    if (follow_loop) {
      in.acquisition_streaming = out.loop == LoopCommand::run;
      in.acquisition_verified = in.acquisition_streaming;
    }
    now += kMs;
    return out;
  }
  void start() {
    in.start_requested = true;
    step();
  }
  void stop() {
    in.stop_requested = true;
    step();
  }
  // Arms and steps until scanning.
  void scan() {
    start();
    for (int i = 0; i < 5 && machine.state() != SafetyState::scanning; ++i) step();
    ASSERT_EQ(machine.state(), SafetyState::scanning);
  }

  SafetyStateMachine machine;
  SafetyInputs in{.now_ns = 0, .lines = {true, true, true, true}};
  SafetyOutputs last;
  std::uint64_t now = 1000 * kMs;
  bool follow_emission = true;
  bool follow_loop = true;
};

TEST(SafetyStateMachine, IdleKeepsEmissionOffAndTheGalvosParked) {
  Bench b;
  for (int i = 0; i < 3; ++i) {
    const SafetyOutputs out = b.step();
    EXPECT_FALSE(out.emission);
    EXPECT_EQ(out.loop, LoopCommand::park);
    EXPECT_TRUE(out.feed_watchdog);
  }
  EXPECT_EQ(b.machine.state(), SafetyState::idle);
  b.stop();  // nothing to stop
  EXPECT_EQ(b.machine.state(), SafetyState::idle);
}

TEST(SafetyStateMachine, StartArmsThenEmitsOnlyOnceVerifiedAndReadBack) {
  Bench b;
  b.follow_loop = false;
  b.start();
  EXPECT_EQ(b.machine.state(), SafetyState::arming);
  EXPECT_EQ(b.last.loop, LoopCommand::run);
  EXPECT_FALSE(b.last.emission) << "not before the acquisition is verified";
  b.in.acquisition_streaming = true;
  b.step();
  EXPECT_FALSE(b.last.emission) << "streaming is not enough: a good group must be out";
  b.in.acquisition_verified = true;
  b.step();
  EXPECT_TRUE(b.last.emission);
  EXPECT_EQ(b.machine.state(), SafetyState::arming) << "until the line reads back on";
  b.step();  // read-back on
  EXPECT_EQ(b.machine.state(), SafetyState::scanning);
  EXPECT_TRUE(b.last.emission);
  EXPECT_EQ(b.machine.record().arms_total, 1u);
  EXPECT_NE(b.machine.record().emission_on_ns, 0u);
}

struct FaultCase {
  const char* name;
  std::uint32_t expected;
  void (*inject)(SafetyInputs&);
};

class ScanningFault : public testing::TestWithParam<FaultCase> {};

TEST_P(ScanningFault, DropsEmissionAndParksInTheSameStepThenSettlesSafe) {
  Bench b;
  b.machine = SafetyStateMachine([] {
    SafetyPolicy p = policy();
    p.require_footswitch = true;
    return p;
  }());
  b.scan();
  const std::uint64_t fault_at = b.now;
  GetParam().inject(b.in);
  if (std::string(GetParam().name) == "stall") b.now += 60 * kMs;
  b.in.now_ns = b.now;
  const SafetyOutputs out = b.machine.step(b.in);  // heartbeat not refreshed for the stall case
  EXPECT_EQ(b.machine.state(), SafetyState::fault);
  EXPECT_FALSE(out.emission) << "emission off in the step that saw the fault";
  EXPECT_EQ(out.loop, LoopCommand::park) << "park commanded in the same step";
  EXPECT_NE(b.machine.record().faults & GetParam().expected, 0u)
      << describe_faults(b.machine.record().faults);
  EXPECT_GE(b.machine.record().fault_ns, fault_at);
  EXPECT_EQ(b.machine.record().faults_total, 1u);

  // The world follows: emission reads back off, the acquisition parks. The next step confirms.
  b.in.emission_readback = false;
  b.in.acquisition_streaming = false;
  b.in.acquisition_faults = 0;
  b.now += kMs;
  b.step();
  EXPECT_EQ(b.machine.state(), SafetyState::safe);
  const SafetyRecord& r = b.machine.record();
  EXPECT_LE(r.emission_off_ns - r.fault_ns, kMs) << "confirmed one poll after the fault";
  EXPECT_LE(r.parked_ns - r.fault_ns, kMs);
  EXPECT_NE(r.faults & GetParam().expected, 0u) << "the cause stays latched in safe";
}

INSTANTIATE_TEST_SUITE_P(
    Causes, ScanningFault,
    testing::Values(
        FaultCase{"digitizer_timeout", kFaultDigitizerTimeout,
                  [](SafetyInputs& in) { in.acquisition_faults = kFaultDigitizerTimeout; }},
        FaultCase{"digitizer_lost", kFaultDigitizerLost,
                  [](SafetyInputs& in) { in.acquisition_faults = kFaultDigitizerLost; }},
        FaultCase{"clock_fault_in_group", kFaultClockLost,
                  [](SafetyInputs& in) { in.acquisition_faults = kFaultClockLost; }},
        FaultCase{"k_clock_line", kFaultClockLost,
                  [](SafetyInputs& in) { in.lines.k_clock_valid = false; }},
        FaultCase{"trigger_line", kFaultTriggerLost,
                  [](SafetyInputs& in) { in.lines.sweep_trigger_present = false; }},
        FaultCase{"missed_triggers", kFaultTriggerLost,
                  [](SafetyInputs& in) { in.acquisition_faults = kFaultTriggerLost; }},
        FaultCase{"galvo_underrun", kFaultGalvoUnderrun,
                  [](SafetyInputs& in) { in.acquisition_faults = kFaultGalvoUnderrun; }},
        FaultCase{"galvo_fault", kFaultGalvoFault,
                  [](SafetyInputs& in) { in.acquisition_faults = kFaultGalvoFault; }},
        FaultCase{"deadline_misses", kFaultDeadlineMisses,
                  [](SafetyInputs& in) { in.acquisition_faults = kFaultDeadlineMisses; }},
        FaultCase{"acquisition_failed", kFaultAcquisitionFailed,
                  [](SafetyInputs& in) { in.acquisition_faults = kFaultAcquisitionFailed; }},
        FaultCase{"laser_not_ready", kFaultLaserNotReady,
                  [](SafetyInputs& in) { in.lines.laser_ready = false; }},
        FaultCase{"footswitch_released", kFaultFootswitch,
                  [](SafetyInputs& in) { in.lines.footswitch = false; }},
        FaultCase{"emission_dropped", kFaultEmissionReadback,
                  [](SafetyInputs& in) { in.emission_readback = false; }},
        FaultCase{"stall", kFaultAcquisitionStalled, [](SafetyInputs&) {}}),
    [](const testing::TestParamInfo<FaultCase>& c) { return std::string(c.param.name); });

TEST(SafetyStateMachine, ArmingFaultsGoToFault) {
  {
    Bench b;
    b.follow_loop = false;
    b.start();
    b.in.acquisition_faults = kFaultStartFailed;
    b.step();
    EXPECT_EQ(b.machine.state(), SafetyState::fault);
    EXPECT_EQ(b.machine.record().faults, kFaultStartFailed);
  }
  {
    Bench b;  // a start with the k-clock down faults at once, emission never driven
    b.in.lines.k_clock_valid = false;
    b.start();
    EXPECT_EQ(b.machine.state(), SafetyState::fault);
    EXPECT_FALSE(b.last.emission);
  }
  {
    Bench b;  // never verified
    b.follow_loop = false;
    b.start();
    b.in.acquisition_streaming = true;
    while (b.machine.state() == SafetyState::arming && b.now < 2000 * kMs) b.step();
    EXPECT_EQ(b.machine.state(), SafetyState::fault);
    EXPECT_EQ(b.machine.record().faults, kFaultArmingTimeout);
    EXPECT_GE(b.machine.record().fault_ns - b.machine.record().state_entered_ns, 0u);
  }
  {
    Bench b;  // emission reads back on although nothing drove it
    b.follow_loop = false;
    b.follow_emission = false;
    b.start();
    b.in.emission_readback = true;
    b.step();
    EXPECT_EQ(b.machine.state(), SafetyState::fault);
    EXPECT_EQ(b.machine.record().faults, kFaultEmissionReadback);
  }
  {
    Bench b;  // driven on, never reads back on
    b.follow_emission = false;
    b.start();
    for (int i = 0; i < 20 && b.machine.state() == SafetyState::arming; ++i) b.step();
    EXPECT_EQ(b.machine.state(), SafetyState::fault);
    EXPECT_EQ(b.machine.record().faults, kFaultEmissionReadback);
  }
}

TEST(SafetyStateMachine, StopWhileArmingOrScanningEndsIdleOnceOffAndParked) {
  for (const bool scanning : {false, true}) {
    Bench b;
    if (scanning) {
      b.scan();
    } else {
      b.follow_loop = false;
      b.start();
    }
    b.stop();
    EXPECT_EQ(b.machine.state(), SafetyState::stopping);
    EXPECT_FALSE(b.last.emission);
    EXPECT_EQ(b.last.loop, LoopCommand::park);
    b.in.acquisition_streaming = false;
    b.step();
    EXPECT_EQ(b.machine.state(), SafetyState::idle) << (scanning ? "scanning" : "arming");
    EXPECT_EQ(b.machine.record().faults_total, 0u) << "a stop is not a fault";
  }
}

TEST(SafetyStateMachine, FaultIsNotLeftBeforeReadBackAndParkAreConfirmed) {
  Bench b;
  b.scan();
  b.follow_emission = false;
  b.follow_loop = false;
  b.in.acquisition_faults = kFaultGalvoFault;
  b.step();
  ASSERT_EQ(b.machine.state(), SafetyState::fault);
  // Still emitting and streaming: stays in fault, keeps commanding off and park.
  for (int i = 0; i < 5; ++i) {
    const SafetyOutputs out = b.step();
    EXPECT_FALSE(out.emission);
    EXPECT_EQ(out.loop, LoopCommand::park);
    EXPECT_TRUE(out.feed_watchdog) << "within the read-back timeout";
  }
  b.in.emission_readback = false;
  b.step();
  EXPECT_EQ(b.machine.state(), SafetyState::fault) << "parked not confirmed yet";
  // A cause found while parking joins the latched ones.
  b.in.acquisition_faults |= kFaultGalvoUnderrun;
  b.in.acquisition_streaming = false;
  b.step();
  EXPECT_EQ(b.machine.state(), SafetyState::safe);
  EXPECT_EQ(b.machine.record().faults, kFaultGalvoFault | kFaultGalvoUnderrun);
}

TEST(SafetyStateMachine, EmissionThatWillNotGoOffStopsFeedingTheExternalWatchdog) {
  Bench b;
  b.scan();
  b.follow_emission = false;
  b.in.emission_readback = true;  // stuck on
  b.in.lines.k_clock_valid = false;
  b.step();
  ASSERT_EQ(b.machine.state(), SafetyState::fault);
  bool starved = false;
  for (int i = 0; i < 30; ++i) starved = starved || !b.step().feed_watchdog;
  EXPECT_TRUE(starved) << "after readback_timeout the watchdog is no longer fed";
  EXPECT_TRUE(b.machine.record().emission_off_unverified);
  EXPECT_EQ(b.machine.state(), SafetyState::fault);
  b.in.emission_readback = false;  // finally off (e.g. the external watchdog cut it)
  b.step();
  EXPECT_EQ(b.machine.state(), SafetyState::safe);
  EXPECT_TRUE(b.last.feed_watchdog);
}

TEST(SafetyStateMachine, StartDuringAFaultIsRefused) {
  Bench b;
  b.scan();
  b.follow_loop = false;
  b.in.acquisition_faults = kFaultDigitizerTimeout;
  b.step();
  b.start();
  EXPECT_EQ(b.machine.state(), SafetyState::fault);
  EXPECT_FALSE(b.machine.refusal().empty());
}

TEST(SafetyStateMachine, ReArmFromSafeRecoversToScanningOnceTheCauseIsCleared) {
  Bench b;
  b.scan();
  b.in.lines.k_clock_valid = false;
  b.step();
  b.step();
  ASSERT_EQ(b.machine.state(), SafetyState::safe);
  b.start();
  EXPECT_EQ(b.machine.state(), SafetyState::safe) << "k-clock still down";
  EXPECT_NE(std::string(b.machine.refusal()).find("cannot re-arm"), std::string::npos);
  b.in.lines.k_clock_valid = true;
  b.scan();
  EXPECT_EQ(b.machine.record().arms_total, 2u);
  EXPECT_EQ(b.machine.record().faults, 0u) << "cleared by the re-arm";
  EXPECT_EQ(b.machine.record().faults_total, 1u);
}

TEST(SafetyStateMachine, SafeStopGoesIdleAndAutoReArmWaitsItsDelay) {
  {
    Bench b;
    b.scan();
    b.in.acquisition_faults = kFaultDeadlineMisses;
    b.step();
    b.in.acquisition_faults = 0;
    b.step();
    ASSERT_EQ(b.machine.state(), SafetyState::safe);
    b.stop();
    EXPECT_EQ(b.machine.state(), SafetyState::idle);
    EXPECT_EQ(b.machine.record().faults, 0u);
  }
  {
    SafetyPolicy p = policy();
    p.auto_rearm_delay_ns = 20 * kMs;
    Bench b(p);
    b.scan();
    b.in.acquisition_faults = kFaultDeadlineMisses;
    b.step();
    b.in.acquisition_faults = 0;
    b.step();
    ASSERT_EQ(b.machine.state(), SafetyState::safe);
    const std::uint64_t entered = b.machine.record().state_entered_ns;
    while (b.machine.state() == SafetyState::safe) b.step();
    EXPECT_EQ(b.machine.state(), SafetyState::arming);
    EXPECT_GE(b.machine.record().state_entered_ns - entered, 20 * kMs);
    b.step();
    b.step();
    EXPECT_EQ(b.machine.state(), SafetyState::scanning);
  }
}

TEST(SafetyStateMachine, EmissionReadBackOnWhileIdleOrSafeIsAFault) {
  Bench b;
  b.follow_emission = false;
  b.in.emission_readback = true;
  b.step();
  EXPECT_EQ(b.machine.state(), SafetyState::fault);
  EXPECT_EQ(b.machine.record().faults, kFaultEmissionReadback);
  b.in.emission_readback = false;
  b.step();
  EXPECT_EQ(b.machine.state(), SafetyState::safe);
  b.in.emission_readback = true;
  b.step();
  EXPECT_EQ(b.machine.state(), SafetyState::fault);
}

TEST(SafetyStateMachine, FaultNamesAreListed) {
  EXPECT_EQ(describe_faults(0), "none");
  EXPECT_EQ(describe_faults(kFaultClockLost | kFaultGalvoUnderrun), "k_clock_lost,galvo_underrun");
}

}  // namespace
}  // namespace ioct::rt
