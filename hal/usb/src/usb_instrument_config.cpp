#include "ioct/hal/usb/usb_instrument_config.hpp"

#include "ioct/common/config_error.hpp"

namespace ioct::hal::usb {

void UsbInstrumentConfig::validate() const {
  if (vendor_id == 0) throw ConfigError("usb.vendor_id", "0", "must name the instrument's vendor");
  require_integer_in_range("usb.transfers_in_flight", transfers_in_flight, 1, 256);
  require_integer_in_range("usb.transfer_bytes", transfer_bytes, 1024, 16u << 20);
  if (transfer_bytes % 1024 != 0) {
    throw ConfigError("usb.transfer_bytes", format_value(std::uint64_t{transfer_bytes}),
                      "must be a multiple of 1024 so that every transfer is whole packets");
  }
  require_integer_in_range("usb.staging_buffers", staging_buffers, 4, 4096);
  require_integer_in_range("usb.galvo_transfers_in_flight", galvo_transfers_in_flight, 1, 64);
  require_integer_in_range("usb.galvo_transfer_bytes", galvo_transfer_bytes, 1024, 1u << 20);
  if (galvo_transfer_bytes % 1024 != 0) {
    throw ConfigError("usb.galvo_transfer_bytes", format_value(std::uint64_t{galvo_transfer_bytes}),
                      "must be a multiple of 1024 so that every transfer is whole packets");
  }
  require_integer_in_range("usb.control_timeout_ms", control_timeout_ms, 10, 60'000);
}

}  // namespace ioct::hal::usb
