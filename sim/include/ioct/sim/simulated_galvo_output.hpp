// The simulated galvo output: hal::GalvoOutput over the bench's scanner. Samples written are
// clocked out one per sweep as the simulated digitizer records (the digitizer is the bench's
// clock), and the mirrors follow them with their dynamics, so the digitizer sees the sample
// where the mirrors actually point. Faults (usb_disconnect, galvo_driver_fault,
// galvo_stream_stall) show in status() as the real DAC stream reports them.
#pragma once

#include <memory>

#include "ioct/hal/galvo_output.hpp"
#include "ioct/sim/simulated_bench.hpp"

namespace ioct::sim {

class SimulatedGalvoOutput final : public hal::GalvoOutput {
 public:
  // Attaches to `bench`: from now on the bench's beam follows this output's mirrors.
  explicit SimulatedGalvoOutput(std::shared_ptr<SimulatedBench> bench);

  std::string_view backend() const noexcept override { return "simulated"; }
  SimulatedBench& bench() const noexcept { return *bench_; }

 protected:
  // prepare() and start() throw std::runtime_error while the USB device is unplugged.
  void do_prepare(const hal::GalvoOutputConfig& config) override;
  void do_start() override;
  std::size_t do_write(std::span<const hal::GalvoSample> samples) noexcept override;
  hal::GalvoStatus do_status() const noexcept override;
  void do_park() noexcept override;

 private:
  std::shared_ptr<SimulatedBench> bench_;
};

}  // namespace ioct::sim
