// Every injectable fault shows in the status as the real backends report it: GroupInfo flags,
// missed sweeps and counters; GalvoStatus faults; LineInputs. Faults are switched from another
// thread while the acquisition runs.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>
#include <vector>

#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/sim/simulated_galvo_output.hpp"
#include "ioct/sim/simulated_lines.hpp"
#include "spectrum_fft.hpp"

namespace ioct::sim {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr std::uint16_t kUntouched = 0xBEEF;

class FaultInjection : public testing::Test {
 protected:
  void SetUp() override {
    geometry_.samples_per_ascan = 256;
    geometry_.ascans_per_bscan = 32;
    geometry_.flyback_sweeps = 2;
    geometry_.bscans_per_group = 2;
    geometry_.timeout_ms = 20;
    simulation_.scan.ascans_per_bscan = 32;
    simulation_.scan.bscans_per_volume = 4;
    simulation_.bench.digitizer_buffer_sweeps = 100;
  }
  void make(bool with_galvo = false) {
    bench_ = std::make_shared<SimulatedBench>(simulation_.bench);
    if (with_galvo) {
      galvo_ = std::make_unique<SimulatedGalvoOutput>(bench_);
      hal::GalvoOutputConfig config;
      config.fifo_capacity = 4096;
      galvo_->prepare(config);
      galvo_->write(std::vector<hal::GalvoSample>(2000, hal::GalvoSample{0.1f, 0.2f}));
      galvo_->start();
    }
    digitizer_ = std::make_unique<SimulatedDigitizer>(simulation_, bench_);
    digitizer_->prepare(geometry_);
    digitizer_->start();
    group_.assign(geometry_.samples_per_group(), kUntouched);
  }
  hal::GroupInfo acquire() {
    hal::GroupInfo info;
    info.status = 0xFFFF;
    std::fill(group_.begin(), group_.end(), kUntouched);
    digitizer_->acquire_group(group_, info);
    return info;
  }
  std::uint64_t sweeps_per_group() const { return geometry_.sweeps_per_group(); }
  FaultInjector& faults() { return bench_->faults(); }

  hal::DigitizerConfig geometry_;
  SimulationConfig simulation_;
  std::shared_ptr<SimulatedBench> bench_;
  std::unique_ptr<SimulatedGalvoOutput> galvo_;
  std::unique_ptr<SimulatedDigitizer> digitizer_;
  std::vector<std::uint16_t> group_;
};

TEST_F(FaultInjection, MissedSweepsShowInTheNextGroupAndTheCounterSkipsThem) {
  make();
  EXPECT_EQ(acquire().status, 0u);
  faults().inject_missed_sweeps(37);
  const hal::GroupInfo info = acquire();
  EXPECT_EQ(info.status, hal::kGroupMissedTriggers);
  EXPECT_EQ(info.missed_sweeps, 37u);
  EXPECT_EQ(info.first_sweep_counter, sweeps_per_group() + 37);
  const hal::GroupInfo next = acquire();
  EXPECT_EQ(next.status, 0u);
  EXPECT_EQ(next.missed_sweeps, 0u);
  EXPECT_EQ(next.first_sweep_counter, 2 * sweeps_per_group() + 37);
}

TEST_F(FaultInjection, KClockDropoutFlagsClockFaultAndFallsBackToTimeLinearSampling) {
  make();
  hal::LineInputs inputs = bench_->inputs();
  EXPECT_TRUE(inputs.k_clock_valid);
  SimulatedDigitizer clean(simulation_);  // same seed, never faulted
  clean.prepare(geometry_);
  clean.start();
  std::vector<std::uint16_t> reference(geometry_.samples_per_group());
  hal::GroupInfo reference_info;
  clean.acquire_group(reference, reference_info);

  faults().set(Fault::k_clock_dropout, true);
  EXPECT_FALSE(bench_->inputs().k_clock_valid);
  const hal::GroupInfo info = acquire();
  EXPECT_EQ(info.status, hal::kGroupClockFault);
  EXPECT_EQ(info.missed_sweeps, 0u);
  EXPECT_NE(group_, reference) << "the records are sampled off the k-clock";
  faults().set(Fault::k_clock_dropout, false);
  EXPECT_EQ(acquire().status, 0u);
  EXPECT_TRUE(bench_->inputs().k_clock_valid);

  // A digitizer on its own clock does not notice (the lines still do).
  geometry_.clock_source = hal::ClockSource::internal;
  make();
  faults().set(Fault::k_clock_dropout, true);
  EXPECT_EQ(acquire().status, 0u);
  EXPECT_FALSE(bench_->inputs().k_clock_valid);
}

TEST_F(FaultInjection, DigitizerStallTimesOutThenReportsTheLostSweepsAsOverrun) {
  make();
  acquire();
  faults().set(Fault::digitizer_stall, true);
  const auto started = Clock::now();
  const hal::GroupInfo stalled = acquire();
  const auto waited = Clock::now() - started;
  EXPECT_EQ(stalled.status, hal::kGroupTimeout);
  EXPECT_EQ(stalled.missed_sweeps, 0u);
  EXPECT_GE(waited, 20ms) << "it waits timeout_ms for a record";
  EXPECT_LT(waited, 2s);
  EXPECT_TRUE(std::all_of(group_.begin(), group_.end(), [](auto v) { return v == kUntouched; }))
      << "no data";
  EXPECT_EQ(acquire().status, hal::kGroupTimeout);
  faults().set(Fault::digitizer_stall, false);
  const hal::GroupInfo after = acquire();
  // The source swept on for 2 x 20 ms at 100 kHz while nothing was recorded.
  EXPECT_EQ(after.status, hal::kGroupOverrun);
  EXPECT_EQ(after.missed_sweeps, 4000u);
  EXPECT_EQ(after.first_sweep_counter, sweeps_per_group() + 4000);
  EXPECT_EQ(acquire().status, 0u);
}

TEST_F(FaultInjection, TriggerLossTimesOutStopsTheGalvoClockAndShowsOnTheLine) {
  make(true);
  acquire();
  const std::uint64_t output_before = galvo_->status().samples_output;
  EXPECT_EQ(output_before, sweeps_per_group());
  faults().set(Fault::trigger_loss, true);
  EXPECT_FALSE(bench_->inputs().sweep_trigger_present);
  const hal::GroupInfo lost = acquire();
  EXPECT_EQ(lost.status, hal::kGroupTimeout);
  EXPECT_EQ(galvo_->status().samples_output, output_before) << "the DAC is clocked by the trigger";
  faults().set(Fault::trigger_loss, false);
  const hal::GroupInfo after = acquire();
  EXPECT_EQ(after.status, hal::kGroupMissedTriggers);
  EXPECT_EQ(after.missed_sweeps, 2000u);
  EXPECT_TRUE(bench_->inputs().sweep_trigger_present);
}

TEST_F(FaultInjection, UsbDisconnectLosesTheDeviceUntilItIsBackAndRestarted) {
  // A timeout far longer than any preemption of this thread (a sanitizer's build on a loaded
  // machine), so that "at once" cannot be confused with "after the timeout".
  geometry_.timeout_ms = 2000;
  make(true);
  acquire();
  faults().set(Fault::usb_disconnect, true);
  const auto started = Clock::now();
  const hal::GroupInfo lost = acquire();
  EXPECT_LT(Clock::now() - started, 1s) << "at once, not after the 2 s timeout";
  EXPECT_EQ(lost.status, hal::kGroupDeviceLost);
  EXPECT_EQ(galvo_->status().faults & hal::kGalvoDeviceLost, hal::kGalvoDeviceLost);
  EXPECT_EQ(galvo_->write(std::vector<hal::GalvoSample>(10)), 0u);
  faults().set(Fault::usb_disconnect, false);
  EXPECT_EQ(acquire().status, hal::kGroupDeviceLost) << "gone until re-opened";
  EXPECT_EQ(galvo_->status().faults & hal::kGalvoDeviceLost, hal::kGalvoDeviceLost) << "sticky";

  faults().set(Fault::usb_disconnect, true);
  digitizer_->stop();
  EXPECT_THROW(digitizer_->start(), std::runtime_error) << "cannot open an unplugged device";
  galvo_->stop();
  EXPECT_THROW(galvo_->start(), std::runtime_error);
  faults().set(Fault::usb_disconnect, false);
  digitizer_->start();
  galvo_->write(std::vector<hal::GalvoSample>(200, hal::GalvoSample{0.1f, 0.2f}));
  galvo_->start();
  const hal::GroupInfo back = acquire();
  EXPECT_EQ(back.status, 0u);
  EXPECT_EQ(back.first_sweep_counter, 0u);
  EXPECT_EQ(galvo_->status().faults, 0u);
}

TEST_F(FaultInjection, GalvoDriverFaultIsReportedAndTheMirrorsReturnToRest) {
  make(true);
  acquire();
  acquire();  // the mirrors come from the park position: let them settle
  EXPECT_NEAR(digitizer_->last_group_truth().beam_x.back(), 0.1f, 1e-3f);
  faults().set(Fault::galvo_driver_fault, true);
  EXPECT_EQ(galvo_->status().faults, hal::kGalvoDriverFault);
  acquire();
  acquire();
  EXPECT_NEAR(digitizer_->last_group_truth().beam_x.back(), 0.0f, 1e-3f) << "no drive: rest";
  faults().set(Fault::galvo_driver_fault, false);
  EXPECT_EQ(galvo_->status().faults, hal::kGalvoDriverFault) << "sticky until the next start";
  galvo_->stop();
  galvo_->start();
  EXPECT_EQ(galvo_->status().faults, 0u);
}

TEST_F(FaultInjection, GalvoStreamStallRunsTheFifoDry) {
  make(true);
  faults().set(Fault::galvo_stream_stall, true);
  EXPECT_EQ(galvo_->write(std::vector<hal::GalvoSample>(10)), 0u);
  const std::uint32_t groups = 2000 / static_cast<std::uint32_t>(sweeps_per_group()) + 1;
  for (std::uint32_t g = 0; g < groups; ++g) acquire();
  const hal::GalvoStatus status = galvo_->status();
  EXPECT_EQ(status.fifo_fill, 0u);
  EXPECT_EQ(status.underruns, 1u);
  EXPECT_EQ(status.faults, hal::kGalvoUnderrun);
  EXPECT_EQ(status.samples_output, 2000u);
  faults().set(Fault::galvo_stream_stall, false);
  EXPECT_EQ(galvo_->write(std::vector<hal::GalvoSample>(10)), 10u);
}

TEST_F(FaultInjection, SlowConsumerOverflowsTheOnBoardMemory) {
  make();
  faults().set_slow_consumer_delay_us(1500);  // 150 sweeps late per group; the board holds 100
  faults().set(Fault::slow_consumer, true);
  const auto started = Clock::now();
  const hal::GroupInfo first = acquire();
  EXPECT_GE(Clock::now() - started, 1500us) << "the host really is slow";
  EXPECT_EQ(first.status, hal::kGroupOverrun);
  EXPECT_EQ(first.missed_sweeps, 50u);
  const hal::GroupInfo second = acquire();
  EXPECT_EQ(second.status, hal::kGroupOverrun);
  EXPECT_EQ(second.missed_sweeps, 150u);
  EXPECT_EQ(second.first_sweep_counter, first.first_sweep_counter + sweeps_per_group() + 150);
  faults().set(Fault::slow_consumer, false);
  EXPECT_EQ(acquire().status, 0u);
}

TEST_F(FaultInjection, LaserNotReadyDarkensTheSampleAndShowsOnTheLines) {
  make();
  faults().set(Fault::laser_not_ready, true);
  EXPECT_FALSE(bench_->inputs().laser_ready);
  EXPECT_EQ(acquire().status, 0u) << "the digitizer records what it gets";
  const auto [low, high] = std::minmax_element(group_.begin(), group_.end());
  EXPECT_LT(*high - *low, 40) << "no light: only the offset and read noise";
  faults().set(Fault::laser_not_ready, false);
  acquire();
  const auto [low_on, high_on] = std::minmax_element(group_.begin(), group_.end());
  EXPECT_GT(*high_on - *low_on, 200);
}

TEST_F(FaultInjection, FaultsSwitchedFromAnotherThreadWhileAcquiring) {
  geometry_.timeout_ms = 2;
  make(true);
  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> injected{0};
  std::thread switcher([&] {
    std::uint32_t round = 0;
    while (!done.load()) {
      faults().set(Fault::k_clock_dropout, round % 2 == 0);
      faults().inject_missed_sweeps(3);
      injected.fetch_add(3);
      (void)galvo_->status();
      (void)bench_->inputs();
      ++round;
      std::this_thread::sleep_for(200us);
    }
    faults().set(Fault::k_clock_dropout, false);
  });
  std::uint64_t missed = 0;
  std::uint64_t expected_counter = 0;
  for (int g = 0; g < 40; ++g) {
    const hal::GroupInfo info = acquire();
    EXPECT_EQ(info.status & ~(hal::kGroupClockFault | hal::kGroupMissedTriggers), 0u);
    EXPECT_EQ(info.first_sweep_counter, expected_counter + info.missed_sweeps);
    expected_counter = info.first_sweep_counter + sweeps_per_group();
    missed += info.missed_sweeps;
  }
  done.store(true);
  switcher.join();
  missed += acquire().missed_sweeps;  // those injected after the last group
  EXPECT_EQ(missed, injected.load()) << "every injected sweep is accounted for exactly once";
}

}  // namespace
}  // namespace ioct::sim
