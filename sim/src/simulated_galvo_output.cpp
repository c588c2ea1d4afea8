#include "ioct/sim/simulated_galvo_output.hpp"

#include <stdexcept>

namespace ioct::sim {
namespace {

void require_connected(const SimulatedBench& bench, const char* what) {
  if (bench.faults().active(Fault::usb_disconnect)) {
    throw std::runtime_error(std::string("simulated galvo output: ") + what +
                             ": the USB device is not connected (usb_disconnect)");
  }
}

}  // namespace

SimulatedGalvoOutput::SimulatedGalvoOutput(std::shared_ptr<SimulatedBench> bench)
    : bench_(std::move(bench)) {
  if (!bench_) throw std::invalid_argument("simulated galvo output: no bench");
  bench_->attach_galvo();
}

void SimulatedGalvoOutput::do_prepare(const hal::GalvoOutputConfig& config) {
  require_connected(*bench_, "prepare()");
  bench_->scanner().configure(config);
}

void SimulatedGalvoOutput::do_start() {
  require_connected(*bench_, "start()");
  bench_->scanner().start_stream();
}

std::size_t SimulatedGalvoOutput::do_write(std::span<const hal::GalvoSample> samples) noexcept {
  return bench_->scanner().push(samples);
}

hal::GalvoStatus SimulatedGalvoOutput::do_status() const noexcept {
  return bench_->scanner().status();
}

void SimulatedGalvoOutput::do_park() noexcept {
  bench_->scanner().park();
}

}  // namespace ioct::sim
