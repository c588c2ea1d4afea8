// Which USB instrument to open and how deep its streams are queued.
#pragma once

#include <cstdint>
#include <string>

#include "ioct/hal/usb/usb_protocol.hpp"

namespace ioct::hal::usb {

struct UsbInstrumentConfig {
  std::uint16_t vendor_id = protocol::kPlaceholderVendorId;
  std::uint16_t product_id = protocol::kPlaceholderProductId;
  std::string serial;  // empty: the first instrument with this vendor and product ID

  // Bulk IN transfers queued at once, and the bytes of each. Every wMaxPacketSize USB has (64,
  // 512, 1024) divides a multiple of 1024, so transfers are always whole packets. All of them
  // count against the kernel's usbfs memory limit (/sys/module/usbcore/parameters/usbfs_memory_mb).
  std::uint32_t transfers_in_flight = 16;
  std::uint32_t transfer_bytes = 256 * 1024;
  // Host buffers for record headers, the last partial packet of each record, and data that
  // arrives before acquire_group() has handed over the slot it belongs to. When they run out the
  // host stops reading and the instrument's own FIFO takes up the slack (or overruns).
  std::uint32_t staging_buffers = 32;

  std::uint32_t galvo_transfers_in_flight = 4;
  std::uint32_t galvo_transfer_bytes = 16 * 1024;  // multiple of 1024: whole packets

  // Control requests (configuration, arm, start, stop, park) give up after this.
  std::uint32_t control_timeout_ms = 1000;

  // Throws ConfigError naming the first bad key ("usb.<key>").
  void validate() const;
  friend bool operator==(const UsbInstrumentConfig&, const UsbInstrumentConfig&) = default;
};

}  // namespace ioct::hal::usb
