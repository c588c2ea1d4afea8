// The bulk OUT galvo stream behind UsbGalvoOutput: a lock-free FIFO of encoded samples that the
// writer fills and the instrument's event thread drains into a few bulk OUT transfers, each
// resubmitted from its completion callback while samples are queued.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "ioct/concurrency/spsc_queue.hpp"
#include "ioct/hal/usb/usb_instrument.hpp"
#include "progress_signal.hpp"

struct libusb_transfer;

namespace ioct::hal::usb::detail {

class GalvoStream final : public UsbInstrument::EventClient {
 public:
  explicit GalvoStream(UsbInstrument& instrument);
  ~GalvoStream() override;
  GalvoStream(const GalvoStream&) = delete;
  GalvoStream& operator=(const GalvoStream&) = delete;

  // Set-up: allocates the FIFO (at least `capacity` samples) and the transfers; empties both.
  void configure(std::uint32_t capacity, std::uint32_t transfers, std::uint32_t transfer_bytes);

  // Writer side: queues one encoded sample (x in the low 16 bits, y in the high 16 bits).
  [[nodiscard]] bool push(std::uint32_t sample) noexcept { return fifo_->push(sample); }

  // Any thread but the event thread: cancels the transfers in flight and drops what is queued;
  // false when that did not finish by `deadline_ns`. Counters restart at 0.
  bool flush(std::uint64_t deadline_ns) noexcept;

  std::uint64_t samples_sent() const noexcept { return sent_.load(std::memory_order_acquire); }
  bool lost() const noexcept { return lost_.load(std::memory_order_acquire); }
  std::uint64_t transfer_errors() const noexcept {
    return transfer_errors_.load(std::memory_order_relaxed);
  }

  void on_events_handled() noexcept override;

 private:
  struct Transfer {
    GalvoStream* stream = nullptr;
    libusb_transfer* transfer = nullptr;
    std::unique_ptr<std::uint8_t[]> buffer;
    std::uint32_t index = 0;
  };
  void pump() noexcept;
  static void transfer_done(libusb_transfer* transfer);
  void on_transfer_done(Transfer& transfer) noexcept;
  void free_transfers() noexcept;

  UsbInstrument& instrument_;
  // Made anew by configure() (a queue never changes size), while neither side uses it.
  std::unique_ptr<SpscQueue<std::uint32_t>> fifo_ = std::make_unique<SpscQueue<std::uint32_t>>(1);
  std::vector<Transfer> transfers_;
  std::uint32_t transfer_bytes_ = 0;

  // Event side only.
  std::vector<std::uint32_t> idle_;
  bool flushing_ = false;
  bool configured_ = false;
  std::uint64_t flush_handled_ = 0;

  std::atomic<std::uint64_t> flush_requested_{0};
  std::atomic<std::uint64_t> flush_done_{0};
  ProgressSignal progress_;
  std::atomic<int> in_flight_{0};
  std::atomic<std::uint64_t> sent_{0};
  std::atomic<std::uint64_t> transfer_errors_{0};
  std::atomic<bool> lost_{false};
};

}  // namespace ioct::hal::usb::detail
