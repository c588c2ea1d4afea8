// Errors of the USB backends: what failed, in words a person can act on, with libusb's code.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "ioct/common/error.hpp"

namespace ioct::hal::usb {

// Category device (ioct/common/error.hpp).
class UsbError : public std::runtime_error, public Error {
 public:
  // libusb_code: a LIBUSB_ERROR_* value, or 0 where the failure is not libusb's (a protocol
  // mismatch, a missing endpoint).
  UsbError(const std::string& what, int libusb_code);
  int libusb_code() const noexcept { return libusb_code_; }

 private:
  int libusb_code_;
};

// The kernel's limit on memory for USB transfers submitted through usbfs.
inline constexpr std::string_view kUsbfsMemoryLimitFile =
    "/sys/module/usbcore/parameters/usbfs_memory_mb";

// "<what>: <libusb's name for code> (<its description>)", plus what to do about it where the
// code has a usual cause: LIBUSB_ERROR_ACCESS (device node permissions), LIBUSB_ERROR_BUSY
// (another process holds the interface), LIBUSB_ERROR_NO_DEVICE (unplugged). For
// LIBUSB_ERROR_NO_MEM on a submission, append usbfs_memory_advice().
std::string describe_usb_failure(std::string_view what, int libusb_code);

// What to do when a submission fails with LIBUSB_ERROR_NO_MEM: names the kernel's limit
// /sys/module/usbcore/parameters/usbfs_memory_mb with its current value (read from
// `limit_file`, normally that path) and the bytes this host tried to keep in flight.
std::string usbfs_memory_advice(std::uint64_t bytes_in_flight,
                                std::string_view limit_file = kUsbfsMemoryLimitFile);

}  // namespace ioct::hal::usb
