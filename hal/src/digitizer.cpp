#include "ioct/hal/digitizer.hpp"

#include <stdexcept>
#include <string>

namespace ioct::hal {

void Digitizer::prepare(const DigitizerConfig& config) {
  if (state_ == State::running) {
    throw std::logic_error("digitizer: prepare() while running; stop() first");
  }
  config.validate();
  state_ = State::idle;  // a failed do_prepare leaves the digitizer unprepared
  do_prepare(config);
  config_ = config;
  state_ = State::prepared;
}

void Digitizer::start() {
  if (state_ == State::running) return;
  if (state_ != State::prepared) {
    throw std::logic_error("digitizer: start() before prepare()");
  }
  do_start();
  state_ = State::running;
}

void Digitizer::stop() noexcept {
  if (state_ != State::running) return;
  do_stop();
  state_ = State::prepared;
}

void Digitizer::acquire_group(std::span<std::uint16_t> slot_payload, GroupInfo& info) {
  if (state_ != State::running) {
    throw std::logic_error("digitizer: acquire_group() while not running");
  }
  const std::uint64_t words = config_.samples_per_group();
  if (slot_payload.size() < words) {
    throw std::logic_error("digitizer: acquire_group() payload of " +
                           std::to_string(slot_payload.size()) +
                           " words is smaller than a group (" + std::to_string(words) + " words)");
  }
  do_acquire_group(slot_payload.first(words), info);
}

}  // namespace ioct::hal
