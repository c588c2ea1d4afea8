// The USB instrument's galvo DAC: x/y samples stream over bulk OUT (int16 pairs) into the
// instrument's DAC FIFO, which clocks one out per sweep trigger once GALVO_START is sent.
//
// write() (the real-time thread) only fills a lock-free host FIFO; the instrument's event thread
// drains it into bulk OUT transfers. The instrument reports what it has clocked out, its FIFO
// fill, underruns and driver faults on its status endpoint each millisecond; status() reads the
// latest report. park() sends GALVO_PARK at once (the mirrors go to the park position), then
// drops everything queued on the host and in flight, and sends GALVO_PARK again so nothing that
// was already on its way is clocked out later.
//
// Counting: samples_written counts the samples accepted since the stream was last armed
// (prepare() or park()), a prefill written before start() included, because fifo_fill is what
// is queued ahead of the beam: written - dropped for lead - clocked out.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string_view>

#include "ioct/hal/galvo_output.hpp"
#include "ioct/hal/usb/usb_instrument.hpp"

namespace ioct::hal::usb {

namespace detail {
class GalvoStream;
}

class UsbGalvoOutput final : public GalvoOutput {
 public:
  explicit UsbGalvoOutput(std::shared_ptr<UsbInstrument> instrument);
  ~UsbGalvoOutput() override;

  std::string_view backend() const noexcept override { return "usb"; }
  UsbInstrument& instrument() const noexcept { return *instrument_; }
  // Samples the event thread has handed to the instrument (bulk OUT completed) since armed.
  std::uint64_t samples_sent() const noexcept;
  // Bulk OUT transfers that failed (stall, error) or could not be submitted, since prepare().
  std::uint64_t transfer_errors() const noexcept;

 protected:
  void do_prepare(const GalvoOutputConfig& config) override;
  void do_start() override;
  std::size_t do_write(std::span<const GalvoSample> samples) noexcept override;
  GalvoStatus do_status() const noexcept override;
  void do_park() noexcept override;

 private:
  void apply_park_position(const GalvoOutputConfig& config);
  std::uint64_t samples_output() const noexcept;

  std::shared_ptr<UsbInstrument> instrument_;
  std::unique_ptr<detail::GalvoStream> stream_;
  std::uint64_t applied_connection_ = ~std::uint64_t{0};
  std::uint32_t capacity_ = 0;

  // Writer side (write(): one thread at a time), read by status() from any thread.
  std::atomic<std::uint64_t> accepted_{0};
  std::atomic<std::uint64_t> lead_dropped_{0};
  std::atomic<std::uint32_t> lead_to_drop_{0};
  std::atomic<bool> streaming_{false};
  mutable std::atomic<std::uint32_t> sticky_faults_{0};
};

}  // namespace ioct::hal::usb
