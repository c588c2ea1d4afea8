#include "ioct/hal/usb/usb_galvo_output.hpp"

#include <libusb.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <thread>

#include "galvo_stream.hpp"
#include "ioct/hal/usb/usb_error.hpp"
#include "progress_signal.hpp"

namespace ioct::hal::usb {
namespace {

constexpr std::uint64_t kFlushWaitNs = 1'000'000'000;

std::uint32_t packed_code(const GalvoSample& sample) noexcept {
  return static_cast<std::uint32_t>(static_cast<std::uint16_t>(protocol::galvo_code(sample.x))) |
         (static_cast<std::uint32_t>(static_cast<std::uint16_t>(protocol::galvo_code(sample.y)))
          << 16);
}

}  // namespace

UsbGalvoOutput::UsbGalvoOutput(std::shared_ptr<UsbInstrument> instrument)
    : instrument_(std::move(instrument)),
      stream_(std::make_unique<detail::GalvoStream>(*instrument_)) {}

UsbGalvoOutput::~UsbGalvoOutput() {
  park();
  stream_.reset();
}

std::uint64_t UsbGalvoOutput::samples_sent() const noexcept {
  return stream_->samples_sent();
}

std::uint64_t UsbGalvoOutput::transfer_errors() const noexcept {
  return stream_->transfer_errors();
}

void UsbGalvoOutput::apply_park_position(const GalvoOutputConfig& config) {
  using protocol::Param;
  const struct {
    Param param;
    std::int16_t code;
    const char* key;
  } settings[] = {{Param::galvo_park_x, protocol::galvo_code(config.park.x), "galvo.park.x"},
                  {Param::galvo_park_y, protocol::galvo_code(config.park.y), "galvo.park.y"}};
  for (const auto& s : settings) {
    instrument_->set_param(s.param, static_cast<std::uint16_t>(s.code));
  }
  for (const auto& s : settings) {
    const std::uint32_t in_effect = instrument_->get_param(s.param);
    if (static_cast<std::int16_t>(in_effect & 0xFFFFu) != s.code) {
      throw UsbError("usb: " + instrument_->description() + " did not take " + s.key +
                         " (sent DAC code " + std::to_string(s.code) + ", it reads back " +
                         std::to_string(static_cast<std::int16_t>(in_effect & 0xFFFFu)) + ")",
                     0);
    }
  }
  applied_connection_ = instrument_->connection();
}

void UsbGalvoOutput::do_prepare(const GalvoOutputConfig& config) {
  if (instrument_->device_lost()) instrument_->reconnect();
  apply_park_position(config);
  instrument_->send(protocol::Request::galvo_park);  // parked, DAC FIFO empty
  const UsbInstrumentConfig& usb = instrument_->config();
  stream_->configure(config.fifo_capacity, usb.galvo_transfers_in_flight, usb.galvo_transfer_bytes);
  capacity_ = config.fifo_capacity;
  streaming_.store(false, std::memory_order_release);
  accepted_.store(0, std::memory_order_release);
  lead_dropped_.store(0, std::memory_order_release);
  lead_to_drop_.store(config.lead_samples, std::memory_order_release);
  sticky_faults_.store(0, std::memory_order_release);
}

void UsbGalvoOutput::do_start() {
  if (instrument_->device_lost()) instrument_->reconnect();  // re-enumerates; throws if absent
  if (instrument_->connection() != applied_connection_) apply_park_position(config());
  // The prefill reaches the instrument before its clock starts, or the first sweeps run dry:
  // wait (bounded) until what is queued, or as much as the instrument's FIFO holds, was sent.
  const std::uint64_t queued =
      accepted_.load(std::memory_order_acquire) - lead_dropped_.load(std::memory_order_acquire);
  const std::uint64_t deliverable =
      std::min<std::uint64_t>(queued, instrument_->info().dac_fifo_capacity);
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(instrument_->config().control_timeout_ms);
  while (stream_->samples_sent() < deliverable && !stream_->lost() &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  sticky_faults_.store(0, std::memory_order_release);
  instrument_->send(protocol::Request::galvo_start);
  streaming_.store(true, std::memory_order_release);
}

std::uint64_t UsbGalvoOutput::samples_output() const noexcept {
  const protocol::StatusReport report = instrument_->latest_status();
  const bool current = streaming_.load(std::memory_order_acquire) &&
                       (report.status & protocol::kStatusGalvoStreaming) != 0;
  return current ? report.dac_samples_output : 0;
}

std::size_t UsbGalvoOutput::do_write(std::span<const GalvoSample> samples) noexcept {
  if (stream_->lost() || instrument_->device_lost()) return 0;
  const std::uint64_t queued =
      accepted_.load(std::memory_order_relaxed) - lead_dropped_.load(std::memory_order_relaxed);
  const std::uint64_t output = samples_output();
  const std::uint64_t ahead = queued > output ? queued - output : 0;
  const std::uint64_t room = capacity_ > ahead ? capacity_ - ahead : 0;
  const std::size_t wanted =
      static_cast<std::size_t>(std::min<std::uint64_t>(samples.size(), room));
  std::size_t taken = 0;
  std::uint32_t lead = lead_to_drop_.load(std::memory_order_relaxed);
  std::uint64_t dropped = 0;
  for (; taken < wanted; ++taken) {
    if (lead > 0) {  // lead compensation: the stream starts `lead_samples` into the waveform
      --lead;
      ++dropped;
      continue;
    }
    if (!stream_->push(packed_code(samples[taken]))) break;
  }
  lead_to_drop_.store(lead, std::memory_order_relaxed);
  lead_dropped_.fetch_add(dropped, std::memory_order_relaxed);
  accepted_.fetch_add(taken, std::memory_order_release);
  return taken;
}

GalvoStatus UsbGalvoOutput::do_status() const noexcept {
  const protocol::StatusReport report = instrument_->latest_status();
  const bool current = streaming_.load(std::memory_order_acquire) &&
                       (report.status & protocol::kStatusGalvoStreaming) != 0;
  GalvoStatus s;
  s.samples_written = accepted_.load(std::memory_order_acquire);
  s.samples_output = current ? report.dac_samples_output : 0;
  const std::uint64_t queued = s.samples_written - lead_dropped_.load(std::memory_order_acquire);
  s.fifo_fill = static_cast<std::uint32_t>(
      std::min<std::uint64_t>(queued > s.samples_output ? queued - s.samples_output : 0,
                              std::numeric_limits<std::uint32_t>::max()));
  s.underruns = current ? report.dac_underruns : 0;
  std::uint32_t faults = 0;
  if (s.underruns > 0 || (current && (report.status & protocol::kStatusGalvoUnderrun) != 0)) {
    faults |= kGalvoUnderrun;
  }
  if ((report.status & protocol::kStatusGalvoFault) != 0) faults |= kGalvoDriverFault;
  if (stream_->lost() || instrument_->device_lost()) faults |= kGalvoDeviceLost;
  s.faults = sticky_faults_.fetch_or(faults, std::memory_order_acq_rel) | faults;
  s.parked = !streaming_.load(std::memory_order_acquire);
  return s;
}

void UsbGalvoOutput::do_park() noexcept {
  streaming_.store(false, std::memory_order_release);
  // First the mirrors, at once; then what is queued on the host and in flight; then once more,
  // so that nothing a cancelled transfer had already delivered is clocked out later.
  const int first = instrument_->try_send(protocol::Request::galvo_park);
  stream_->flush(monotonic_ns() + kFlushWaitNs);
  if (first == 0) {
    instrument_->try_send(protocol::Request::galvo_park);
  } else {
    // Unverified park: the instrument is gone, or did not answer.
    sticky_faults_.fetch_or(first == LIBUSB_ERROR_NO_DEVICE ? kGalvoDeviceLost : kGalvoDriverFault,
                            std::memory_order_acq_rel);
  }
  accepted_.store(0, std::memory_order_release);
  lead_dropped_.store(0, std::memory_order_release);
  lead_to_drop_.store(config().lead_samples, std::memory_order_release);
}

}  // namespace ioct::hal::usb
