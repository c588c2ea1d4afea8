#include "ioct/hal/galvo_output.hpp"

#include <cmath>
#include <stdexcept>

#include "ioct/common/config_error.hpp"

namespace ioct::hal {

void GalvoOutputConfig::validate() const {
  require_real_in_range("galvo.sample_rate_hz", sample_rate_hz, 1.0, 10e6);
  require_integer_in_range("galvo.fifo_capacity", fifo_capacity, 16, 1u << 24);
  require_integer_in_range("galvo.lead_samples", lead_samples, 0, fifo_capacity / 2);
  // Named as ioct-rt's file names them, so an error of these is placed at the file's line.
  require_real_in_range("galvo.park_x", park.x, -1.0, 1.0);
  require_real_in_range("galvo.park_y", park.y, -1.0, 1.0);
}

void GalvoOutput::prepare(const GalvoOutputConfig& config) {
  if (state_ == State::running) {
    throw std::logic_error("galvo output: prepare() while running; stop() first");
  }
  config.validate();
  state_ = State::idle;
  do_prepare(config);
  config_ = config;
  state_ = State::prepared;
}

void GalvoOutput::start() {
  if (state_ == State::running) return;
  if (state_ != State::prepared) throw std::logic_error("galvo output: start() before prepare()");
  do_start();
  state_ = State::running;
}

void GalvoOutput::stop() noexcept {
  if (state_ == State::idle) return;
  do_park();
  state_ = State::prepared;
}

std::size_t GalvoOutput::write(std::span<const GalvoSample> samples) noexcept {
  if (state_ == State::idle) return 0;
  return do_write(samples);
}

GalvoStatus GalvoOutput::status() const noexcept {
  if (state_ == State::idle) return GalvoStatus{};
  return do_status();
}

void GalvoOutput::park() noexcept {
  if (state_ == State::idle) return;
  do_park();
  state_ = State::prepared;
}

}  // namespace ioct::hal
