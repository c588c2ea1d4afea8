#include "ioct/hal/usb/usb_error.hpp"

#include <libusb.h>

#include <cstdio>
#include <fstream>
#include <string>

namespace ioct::hal::usb {

UsbError::UsbError(const std::string& what, int libusb_code)
    : std::runtime_error(what), Error(ErrorCategory::device), libusb_code_(libusb_code) {}

std::string usbfs_memory_advice(std::uint64_t bytes_in_flight, std::string_view limit_file) {
  std::string limit = "unreadable";
  if (std::ifstream file{std::string(limit_file)}; file) {
    std::string value;
    if (file >> value) limit = value == "0" ? "0 (no limit)" : value + " MiB";
  }
  char amount[64];
  if (bytes_in_flight >= (1u << 20)) {
    std::snprintf(amount, sizeof(amount), "%.1f MiB",
                  static_cast<double>(bytes_in_flight) / (1024.0 * 1024.0));
  } else {
    std::snprintf(amount, sizeof(amount), "%.1f KiB",
                  static_cast<double>(bytes_in_flight) / 1024.0);
  }
  return "the kernel's usbfs memory limit is exhausted: this host keeps " + std::string(amount) +
         " of USB transfers in flight and " + std::string(limit_file) + " is " + limit +
         "; raise it (e.g. `echo 256 > " + std::string(limit_file) +
         "`, or usbcore.usbfs_memory_mb=256 on the kernel command line) or lower "
         "usb.transfers_in_flight x usb.transfer_bytes";
}

std::string describe_usb_failure(std::string_view what, int libusb_code) {
  std::string text(what);
  text += ": ";
  text += libusb_error_name(libusb_code);
  text += " (";
  text += libusb_strerror(libusb_code);
  text += ")";
  switch (libusb_code) {
    case LIBUSB_ERROR_ACCESS:
      text +=
          "; the device node is not writable by this user: install the udev rule "
          "70-ioct-digitizer.rules (it gives the group ioct-rt access) and run in that group";
      break;
    case LIBUSB_ERROR_BUSY:
      text +=
          "; another process (or kernel driver) holds the interface: is ioct-rt already running?";
      break;
    case LIBUSB_ERROR_NO_DEVICE:
      text += "; the instrument was unplugged or reset";
      break;
    default:
      break;
  }
  return text;
}

}  // namespace ioct::hal::usb
