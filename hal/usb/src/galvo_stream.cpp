#include "galvo_stream.hpp"

#include <libusb.h>

#include <algorithm>
#include <new>

#include "ioct/hal/usb/usb_protocol.hpp"

namespace ioct::hal::usb::detail {

GalvoStream::GalvoStream(UsbInstrument& instrument) : instrument_(instrument) {
  instrument_.attach(this);
}

GalvoStream::~GalvoStream() {
  flush(monotonic_ns() + 1'000'000'000u);
  instrument_.detach(this);
  free_transfers();
}

void GalvoStream::free_transfers() noexcept {
  if (in_flight_.load() != 0) return;  // never free a transfer libusb still owns
  for (Transfer& t : transfers_) libusb_free_transfer(t.transfer);
  transfers_.clear();
}

void GalvoStream::configure(std::uint32_t capacity, std::uint32_t transfers,
                            std::uint32_t transfer_bytes) {
  flush(monotonic_ns() + 1'000'000'000u);
  instrument_.run_on_event_thread([&] {
    free_transfers();
    fifo_ = std::make_unique<SpscQueue<std::uint32_t>>(capacity);
    transfer_bytes_ = transfer_bytes;
    transfers_.resize(transfers);
    idle_.clear();
    idle_.reserve(transfers);
    for (std::uint32_t i = 0; i < transfers; ++i) {
      Transfer& t = transfers_[i];
      t.stream = this;
      t.index = i;
      t.buffer = std::make_unique<std::uint8_t[]>(transfer_bytes);
      t.transfer = libusb_alloc_transfer(0);
      if (t.transfer == nullptr) throw std::bad_alloc();
      idle_.push_back(i);
    }
    sent_.store(0, std::memory_order_release);
    transfer_errors_.store(0, std::memory_order_relaxed);
    lost_.store(false, std::memory_order_release);
    flushing_ = false;
    configured_ = true;
  });
}

bool GalvoStream::flush(std::uint64_t deadline_ns) noexcept {
  if (instrument_.on_event_thread()) return false;  // would wait for itself
  const std::uint64_t request = flush_requested_.fetch_add(1, std::memory_order_acq_rel) + 1;
  instrument_.wake_event_thread();
  for (;;) {
    const std::uint32_t seen = progress_.value();
    if (flush_done_.load(std::memory_order_acquire) >= request) return true;
    if (!progress_.wait(seen, deadline_ns)) {
      return flush_done_.load(std::memory_order_acquire) >= request;
    }
  }
}

void GalvoStream::on_events_handled() noexcept {
  const std::uint64_t requested = flush_requested_.load(std::memory_order_acquire);
  if (!flushing_ && requested > flush_handled_) {
    flushing_ = true;
    flush_handled_ = requested;
    for (Transfer& t : transfers_) libusb_cancel_transfer(t.transfer);  // idle ones: NOT_FOUND
  }
  if (instrument_.device_lost()) lost_.store(true, std::memory_order_release);
  if (flushing_) {
    if (in_flight_.load(std::memory_order_acquire) != 0) return;
    std::uint32_t dropped;
    while (fifo_->pop(dropped)) {
    }
    sent_.store(0, std::memory_order_release);
    flushing_ = false;
    flush_done_.store(flush_handled_, std::memory_order_release);
    progress_.notify();
    return;
  }
  pump();
}

void GalvoStream::pump() noexcept {
  if (!configured_ || flushing_ || lost_.load(std::memory_order_acquire)) return;
  libusb_device_handle* handle = instrument_.handle();
  if (handle == nullptr) return;
  const std::size_t per_transfer = transfer_bytes_ / protocol::kGalvoSampleBytes;
  while (!idle_.empty()) {
    const std::size_t queued = fifo_->size();
    if (queued == 0) return;
    Transfer& t = transfers_[idle_.back()];
    const std::size_t n = std::min(queued, per_transfer);
    std::uint8_t* out = t.buffer.get();
    for (std::size_t i = 0; i < n; ++i) {
      std::uint32_t code = 0;
      static_cast<void>(fifo_->pop(code));  // one of the `queued` items: this side alone pops
      // x then y, each int16 little-endian: the little-endian bytes of the packed word.
      out[4 * i + 0] = static_cast<std::uint8_t>(code);
      out[4 * i + 1] = static_cast<std::uint8_t>(code >> 8);
      out[4 * i + 2] = static_cast<std::uint8_t>(code >> 16);
      out[4 * i + 3] = static_cast<std::uint8_t>(code >> 24);
    }
    libusb_fill_bulk_transfer(t.transfer, handle, protocol::kGalvoEndpoint, out,
                              static_cast<int>(n * protocol::kGalvoSampleBytes), transfer_done, &t,
                              0);
    const int r = libusb_submit_transfer(t.transfer);
    if (r != 0) {
      transfer_errors_.fetch_add(1, std::memory_order_relaxed);
      if (r == LIBUSB_ERROR_NO_DEVICE) {
        lost_.store(true, std::memory_order_release);
        instrument_.mark_lost();
      }
      return;
    }
    idle_.pop_back();
    in_flight_.fetch_add(1, std::memory_order_acq_rel);
  }
}

void GalvoStream::transfer_done(libusb_transfer* transfer) {
  auto* t = static_cast<Transfer*>(transfer->user_data);
  t->stream->on_transfer_done(*t);
}

void GalvoStream::on_transfer_done(Transfer& t) noexcept {
  idle_.push_back(t.index);
  in_flight_.fetch_sub(1, std::memory_order_acq_rel);
  switch (t.transfer->status) {
    case LIBUSB_TRANSFER_COMPLETED:
      sent_.fetch_add(
          static_cast<std::uint64_t>(t.transfer->actual_length) / protocol::kGalvoSampleBytes,
          std::memory_order_acq_rel);
      break;
    case LIBUSB_TRANSFER_CANCELLED:
      break;
    case LIBUSB_TRANSFER_NO_DEVICE:
      lost_.store(true, std::memory_order_release);
      instrument_.mark_lost();
      break;
    case LIBUSB_TRANSFER_STALL:
      libusb_clear_halt(t.transfer->dev_handle, protocol::kGalvoEndpoint);
      transfer_errors_.fetch_add(1, std::memory_order_relaxed);
      break;
    default:
      transfer_errors_.fetch_add(1, std::memory_order_relaxed);
      break;
  }
  if (flushing_) {
    on_events_handled();  // completes the flush once the last transfer is back
    return;
  }
  pump();
}

}  // namespace ioct::hal::usb::detail
