// The USB instrument's digitizer: records stream over bulk IN, one per B-scan, and land in the
// caller's ring slot (docs/usb-protocol.md says how, and what is copied).
//
// prepare() sends the geometry, clock and trigger to the instrument with SET_PARAM, reads every
// value back, plans the transfers and allocates everything. start() arms the instrument (sweep
// counter 0), queues the transfers and starts it. acquire_group() waits for the group's records
// without allocating, locking or logging; what went wrong is in GroupInfo::status and, in
// words, in describe_last_fault() for the housekeeping thread:
//   kGroupTimeout      no record for timeout_ms (the stream is restarted for the next group)
//   kGroupDeviceLost   the instrument was unplugged; start() again reconnects (re-enumerates)
//   kGroupOverrun      the instrument dropped records (its FIFO overflowed), or the host lost
//                      part of the group to a transfer error or a malformed record
//   kGroupClockFault, kGroupMissedTriggers   as the record headers report them
// missed_sweeps counts the sweeps between the group's records and the previous ones that were
// never delivered (dropped records, restarts).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "ioct/hal/digitizer.hpp"
#include "ioct/hal/usb/record_plan.hpp"
#include "ioct/hal/usb/usb_instrument.hpp"

namespace ioct::hal::usb {

namespace detail {
class RecordStream;
struct Completion;
}  // namespace detail

// Why the last faulty group was faulty (UsbDigitizer::last_fault()).
enum class RecordFault : std::uint8_t {
  none,
  timeout,           // no record for timeout_ms
  device_lost,       // LIBUSB_TRANSFER_NO_DEVICE / LIBUSB_ERROR_NO_DEVICE
  transfer_failed,   // a transfer ended in a stall, an error or short
  bad_record,        // a header without the magic, of another geometry, or a counter out of step
  resync_timed_out,  // the stream could not be stopped in time; treated as lost
};
std::string_view to_string(RecordFault fault) noexcept;

struct RecordCounters {
  std::uint64_t groups = 0;           // groups returned
  std::uint64_t faulty_groups = 0;    // groups returned with a fault
  std::uint64_t records = 0;          // record headers accepted
  std::uint64_t resyncs = 0;          // stream restarts after a fault
  std::uint64_t direct_bytes = 0;     // payload received straight into slots
  std::uint64_t staged_bytes = 0;     // payload copied from staging buffers into slots
  std::uint64_t starvations = 0;      // times the host ran out of staging buffers
  std::uint64_t submit_failures = 0;  // transfer submissions libusb refused
};

class UsbDigitizer final : public Digitizer {
 public:
  explicit UsbDigitizer(std::shared_ptr<UsbInstrument> instrument);
  ~UsbDigitizer() override;

  std::string_view backend() const noexcept override { return "usb"; }
  UsbInstrument& instrument() const noexcept { return *instrument_; }
  // The transfer plan of the prepared geometry.
  const RecordPlan& plan() const noexcept { return plan_; }

  RecordCounters counters() const noexcept;
  RecordFault last_fault() const noexcept { return last_fault_.load(std::memory_order_acquire); }
  // The last fault in words, with libusb's status where one was involved. Allocates: call it
  // off the real-time thread.
  std::string describe_last_fault() const;

 protected:
  void do_prepare(const DigitizerConfig& config) override;
  void do_start() override;
  void do_stop() noexcept override;
  void do_acquire_group(std::span<std::uint16_t> group, GroupInfo& info) override;

 private:
  struct Assembly;
  void apply_settings(const DigitizerConfig& config);
  bool take(const detail::Completion& completion, std::uint8_t* slot, Assembly& assembly) noexcept;
  void fail(RecordFault fault, std::int32_t libusb_status, Assembly& assembly,
            GroupInfo& info) noexcept;

  std::shared_ptr<UsbInstrument> instrument_;
  std::unique_ptr<detail::RecordStream> stream_;
  RecordPlan plan_;
  std::uint64_t applied_connection_ = ~std::uint64_t{0};

  // Real-time side.
  std::uint64_t epoch_ = 0;
  std::uint64_t group_ = 0;             // groups since start(), faulty ones included
  std::uint64_t expected_counter_ = 0;  // sweep counter the next record should carry
  std::uint64_t timeout_ns_ = 0;

  std::atomic<RecordFault> last_fault_{RecordFault::none};
  std::atomic<std::int32_t> last_fault_status_{0};
  std::atomic<std::uint64_t> last_fault_group_{0};
  struct AtomicCounters {
    std::atomic<std::uint64_t> groups{0}, faulty_groups{0}, records{0}, resyncs{0}, direct_bytes{0},
        staged_bytes{0};
  } counters_;
};

}  // namespace ioct::hal::usb
