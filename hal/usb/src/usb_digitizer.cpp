#include "ioct/hal/usb/usb_digitizer.hpp"

#include <libusb.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "ioct/common/config_error.hpp"
#include "ioct/hal/usb/usb_error.hpp"
#include "progress_signal.hpp"
#include "record_stream.hpp"

namespace ioct::hal::usb {
namespace {

constexpr std::uint64_t kLostWaitNs = 1'000'000'000;

std::uint32_t group_flag(RecordFault fault) noexcept {
  switch (fault) {
    case RecordFault::timeout:
      return kGroupTimeout;
    case RecordFault::device_lost:
    case RecordFault::resync_timed_out:
      return kGroupDeviceLost;
    case RecordFault::transfer_failed:
    case RecordFault::bad_record:
      return kGroupOverrun;
    case RecordFault::none:
      break;
  }
  return 0;
}

std::string transfer_status_name(std::int32_t status) {
  switch (status) {
    case LIBUSB_TRANSFER_ERROR:
      return "LIBUSB_TRANSFER_ERROR";
    case LIBUSB_TRANSFER_TIMED_OUT:
      return "LIBUSB_TRANSFER_TIMED_OUT";
    case LIBUSB_TRANSFER_CANCELLED:
      return "LIBUSB_TRANSFER_CANCELLED";
    case LIBUSB_TRANSFER_STALL:
      return "LIBUSB_TRANSFER_STALL (the endpoint halted; it was cleared)";
    case LIBUSB_TRANSFER_NO_DEVICE:
      return "LIBUSB_TRANSFER_NO_DEVICE";
    case LIBUSB_TRANSFER_OVERFLOW:
      return "LIBUSB_TRANSFER_OVERFLOW (the instrument sent more than a record holds)";
    case detail::kPartShort:
      return "a short transfer (the instrument ended a record early)";
    default:
      return "status " + std::to_string(status);
  }
}

}  // namespace

std::string_view to_string(RecordFault fault) noexcept {
  switch (fault) {
    case RecordFault::none:
      return "none";
    case RecordFault::timeout:
      return "timeout";
    case RecordFault::device_lost:
      return "device_lost";
    case RecordFault::transfer_failed:
      return "transfer_failed";
    case RecordFault::bad_record:
      return "bad_record";
    case RecordFault::resync_timed_out:
      return "resync_timed_out";
  }
  return "unknown";
}

struct UsbDigitizer::Assembly {
  std::uint64_t next_part = 0;
  bool have_first = false;
  std::uint64_t first_counter = 0;
  std::uint64_t missed = 0;
  std::uint32_t status = 0;
  RecordFault fault = RecordFault::none;
  std::int32_t fault_status = 0;
};

UsbDigitizer::UsbDigitizer(std::shared_ptr<UsbInstrument> instrument)
    : instrument_(std::move(instrument)),
      stream_(std::make_unique<detail::RecordStream>(*instrument_)) {}

UsbDigitizer::~UsbDigitizer() {
  stop();
  stream_.reset();
}

void UsbDigitizer::apply_settings(const DigitizerConfig& config) {
  using protocol::Param;
  struct Setting {
    Param param;
    std::uint32_t value;
    const char* key;
  };
  const Setting settings[] = {
      {Param::samples_per_ascan, config.samples_per_ascan, "digitizer.samples_per_ascan"},
      {Param::ascans_per_bscan, config.ascans_per_bscan, "digitizer.ascans_per_bscan"},
      {Param::flyback_sweeps, config.flyback_sweeps, "digitizer.flyback_sweeps"},
      {Param::clock_source, config.clock_source == ClockSource::internal ? 1u : 0u,
       "digitizer.clock_source"},
      {Param::sweep_rate_hz, static_cast<std::uint32_t>(std::lround(config.ascan_rate_hz)),
       "digitizer.ascan_rate_hz"},
      {Param::trigger_source, config.trigger.source == TriggerSource::software ? 1u : 0u,
       "digitizer.trigger.source"},
      {Param::trigger_level_mv,
       static_cast<std::uint32_t>(
           static_cast<std::int32_t>(std::lround(config.trigger.level_volts * 1000.0))),
       "digitizer.trigger.level_volts"},
      {Param::trigger_delay_samples, config.trigger.delay_samples,
       "digitizer.trigger.delay_samples"},
  };
  for (const Setting& s : settings) instrument_->set_param(s.param, s.value);
  // Read everything back: what the instrument runs with is verified, not assumed.
  for (const Setting& s : settings) {
    const std::uint32_t in_effect = instrument_->get_param(s.param);
    if (in_effect != s.value) {
      throw UsbError("usb: " + instrument_->description() + " did not take " + s.key + " (sent " +
                         std::to_string(s.value) + " as " +
                         std::string(protocol::to_string(s.param)) + ", it reads back " +
                         std::to_string(in_effect) + ")",
                     0);
    }
  }
  applied_connection_ = instrument_->connection();
}

void UsbDigitizer::do_prepare(const DigitizerConfig& config) {
  const protocol::DeviceInfo& info = instrument_->info();
  const std::string& who = instrument_->description();
  if (config.samples_per_ascan > info.max_samples_per_ascan) {
    throw ConfigError("digitizer.samples_per_ascan",
                      format_value(std::uint64_t{config.samples_per_ascan}),
                      "the " + who + " records at most " +
                          std::to_string(info.max_samples_per_ascan) + " samples per A-scan");
  }
  if (config.sample_bits != info.adc_bits) {
    throw ConfigError(
        "digitizer.sample_bits", format_value(std::uint64_t{config.sample_bits}),
        "must be " + std::to_string(info.adc_bits) + ", the ADC resolution of the " + who);
  }
  if (config.clock_source == ClockSource::internal &&
      (info.capabilities & protocol::kCapInternalClock) == 0) {
    throw ConfigError("digitizer.clock_source", "internal",
                      "the " + who + " has no internal clock; use external_k_clock");
  }
  if (config.trigger.source == TriggerSource::software &&
      (info.capabilities & protocol::kCapSoftwareTrigger) == 0) {
    throw ConfigError("digitizer.trigger.source", "software",
                      "the " + who + " has no software trigger; use sweep_input");
  }
  if (instrument_->device_lost()) instrument_->reconnect();
  apply_settings(config);

  const std::uint64_t payload_bytes = config.samples_per_bscan() * sizeof(std::uint16_t);
  try {
    plan_ = RecordPlan::make(instrument_->max_packet_size(protocol::kRecordEndpoint), payload_bytes,
                             config.bscans_per_group, instrument_->config().transfer_bytes);
  } catch (const std::invalid_argument& e) {
    throw UsbError("usb: " + who + ": " + e.what(), 0);
  }
  stream_->configure(plan_, instrument_->config());
  timeout_ns_ = std::uint64_t{config.timeout_ms} * 1'000'000u;
}

void UsbDigitizer::do_start() {
  if (instrument_->device_lost()) instrument_->reconnect();  // re-enumerates; throws if absent
  if (instrument_->connection() != applied_connection_) apply_settings(config());
  group_ = 0;
  expected_counter_ = 0;
  last_fault_.store(RecordFault::none, std::memory_order_release);
  instrument_->send(protocol::Request::acq_arm);  // sweep counter to 0, FIFO flushed
  epoch_ = stream_->start();
  try {
    instrument_->send(protocol::Request::acq_start);
  } catch (...) {
    stream_->halt();
    throw;
  }
}

void UsbDigitizer::do_stop() noexcept {
  instrument_->try_send(protocol::Request::acq_stop);
  stream_->halt();
  if (libusb_device_handle* handle = instrument_->handle();
      handle != nullptr && !instrument_->device_lost()) {
    libusb_clear_halt(handle, protocol::kRecordEndpoint);
  }
}

bool UsbDigitizer::take(const detail::Completion& c, std::uint8_t* slot, Assembly& a) noexcept {
  if (c.group != group_ || c.part != a.next_part) {
    stream_->release(c.staging);
    a.fault = RecordFault::bad_record;  // out of order: cannot happen unless the stream broke
    return false;
  }
  if (c.status != detail::kPartCompleted) {
    a.fault = RecordFault::transfer_failed;
    a.fault_status = c.status;
    return false;
  }
  const RecordPart part = plan_.part(c.part);
  const std::uint8_t* staged =
      c.staging != detail::kNoStaging ? stream_->staging(c.staging) : nullptr;
  switch (part.kind) {
    case PartKind::header: {
      protocol::RecordHeader header;
      const DigitizerConfig& geometry = config();
      const std::uint64_t sweeps_per_bscan = geometry.sweeps_per_bscan();
      const bool valid = protocol::decode({staged, plan_.packet_bytes}, header) &&
                         header.samples_per_ascan == geometry.samples_per_ascan &&
                         header.ascans_per_bscan == geometry.ascans_per_bscan &&
                         header.payload_bytes == plan_.payload_bytes &&
                         header.sweep_counter % sweeps_per_bscan == 0 &&
                         header.sweep_counter >= expected_counter_;
      stream_->release(c.staging);
      if (!valid) {
        a.fault = RecordFault::bad_record;
        return false;
      }
      a.missed += header.sweep_counter - expected_counter_;
      expected_counter_ = header.sweep_counter + sweeps_per_bscan;
      if (!a.have_first) {
        a.have_first = true;
        a.first_counter = header.sweep_counter;
      }
      if ((header.status & protocol::kRecordClockFault) != 0) a.status |= kGroupClockFault;
      if ((header.status & protocol::kRecordOverrun) != 0) a.status |= kGroupOverrun;
      if ((header.status & protocol::kRecordTriggerMissing) != 0 || header.missed_triggers != 0) {
        a.status |= kGroupMissedTriggers;
      }
      counters_.records.fetch_add(1, std::memory_order_relaxed);
      break;
    }
    case PartKind::body:
      if (staged != nullptr) {
        std::memcpy(slot + part.slot_offset, staged, part.length);
        stream_->release(c.staging);
        counters_.staged_bytes.fetch_add(part.length, std::memory_order_relaxed);
      } else {
        counters_.direct_bytes.fetch_add(part.length, std::memory_order_relaxed);
      }
      break;
    case PartKind::tail:
      std::memcpy(slot + part.slot_offset, staged, part.copy_bytes);
      stream_->release(c.staging);
      counters_.staged_bytes.fetch_add(part.copy_bytes, std::memory_order_relaxed);
      break;
  }
  ++a.next_part;
  return true;
}

void UsbDigitizer::do_acquire_group(std::span<std::uint16_t> group, GroupInfo& info) {
  info = GroupInfo{};
  Assembly a;
  detail::RecordStream& stream = *stream_;
  if (stream.lost()) {
    a.fault = RecordFault::device_lost;
    fail(a.fault, 0, a, info);
    return;
  }
  auto* slot = reinterpret_cast<std::uint8_t*>(group.data());
  stream.publish_slot(group_, slot);
  const std::uint64_t parts = plan_.parts_per_group();
  std::uint64_t deadline = monotonic_ns() + timeout_ns_;
  while (a.next_part < parts && a.fault == RecordFault::none) {
    const std::uint32_t seen = stream.progress().value();
    detail::Completion c;
    if (stream.pop(c)) {
      if (c.epoch != epoch_) {  // from before a resync
        stream.release(c.staging);
        continue;
      }
      if (take(c, slot, a)) deadline = monotonic_ns() + timeout_ns_;
      continue;
    }
    if (stream.lost()) {
      a.fault = RecordFault::device_lost;
    } else if (!stream.progress().wait(seen, deadline) && stream.progress().value() == seen &&
               !stream.has_completions()) {
      a.fault = instrument_->device_lost() ? RecordFault::device_lost : RecordFault::timeout;
    }
  }
  if (a.fault != RecordFault::none) {
    fail(a.fault, a.fault_status, a, info);
    return;
  }
  info.first_sweep_counter = a.first_counter;
  info.missed_sweeps = static_cast<std::uint32_t>(
      std::min<std::uint64_t>(a.missed, std::numeric_limits<std::uint32_t>::max()));
  info.status = a.status;
  ++group_;
  counters_.groups.fetch_add(1, std::memory_order_relaxed);
}

void UsbDigitizer::fail(RecordFault fault, std::int32_t libusb_status, Assembly& a,
                        GroupInfo& info) noexcept {
  detail::RecordStream& stream = *stream_;
  const std::uint64_t now = monotonic_ns();
  if (fault == RecordFault::device_lost) {
    stream.wait_idle(now + kLostWaitNs);  // libusb completes every transfer with NO_DEVICE
  } else {
    // Nothing may point into this slot once the caller has it back: cancel everything, then
    // the event side restarts the instrument's stream for the next group.
    ++epoch_;
    counters_.resyncs.fetch_add(1, std::memory_order_relaxed);
    const std::uint64_t limit =
        std::uint64_t{instrument_->config().control_timeout_ms} * 1'000'000u;
    if (!stream.resync(epoch_, group_ + 1, now + limit)) {
      fault = RecordFault::resync_timed_out;
      instrument_->mark_lost();
    }
  }
  info.first_sweep_counter = a.have_first ? a.first_counter : expected_counter_;
  info.missed_sweeps = static_cast<std::uint32_t>(
      std::min<std::uint64_t>(a.missed, std::numeric_limits<std::uint32_t>::max()));
  info.status = a.status | group_flag(fault);
  last_fault_status_.store(libusb_status, std::memory_order_relaxed);
  last_fault_group_.store(group_, std::memory_order_relaxed);
  last_fault_.store(fault, std::memory_order_release);
  ++group_;
  counters_.groups.fetch_add(1, std::memory_order_relaxed);
  counters_.faulty_groups.fetch_add(1, std::memory_order_relaxed);
}

RecordCounters UsbDigitizer::counters() const noexcept {
  RecordCounters c;
  c.groups = counters_.groups.load(std::memory_order_relaxed);
  c.faulty_groups = counters_.faulty_groups.load(std::memory_order_relaxed);
  c.records = counters_.records.load(std::memory_order_relaxed);
  c.resyncs = counters_.resyncs.load(std::memory_order_relaxed);
  c.direct_bytes = counters_.direct_bytes.load(std::memory_order_relaxed);
  c.staged_bytes = counters_.staged_bytes.load(std::memory_order_relaxed);
  c.starvations = stream_->starvations();
  c.submit_failures = stream_->submit_failures();
  return c;
}

std::string UsbDigitizer::describe_last_fault() const {
  const RecordFault fault = last_fault();
  const std::string group = "group " + std::to_string(last_fault_group_.load());
  const std::string& who = instrument_->description();
  std::string text;
  switch (fault) {
    case RecordFault::none:
      return "no fault";
    case RecordFault::timeout:
      text = group + ": no record from the " + who + " for " + std::to_string(config().timeout_ms) +
             " ms (digitizer.timeout_ms): is the sweep trigger connected and the source "
             "sweeping? The stream was restarted";
      break;
    case RecordFault::device_lost:
      text = group + ": the " + who +
             " was unplugged or reset; stop() and start() reconnect once it is back";
      break;
    case RecordFault::transfer_failed:
      text = group + ": a bulk IN transfer ended with " +
             transfer_status_name(last_fault_status_.load()) + "; the stream was restarted";
      break;
    case RecordFault::bad_record:
      text = group +
             ": a record header did not match the protocol or the prepared geometry, or its "
             "sweep counter went backwards; the stream was restarted";
      break;
    case RecordFault::resync_timed_out:
      text = group + ": the stream of the " + who +
             " could not be stopped in time after a fault; treated as lost";
      break;
  }
  if (stream_->last_submit_error() == LIBUSB_ERROR_NO_MEM) {
    text +=
        "; submitting transfers failed: " + usbfs_memory_advice(stream_->bytes_in_flight_limit());
  }
  return text;
}

}  // namespace ioct::hal::usb
