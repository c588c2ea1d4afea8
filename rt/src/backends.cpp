#include "backends.hpp"

#include "ioct/common/config_error.hpp"
#include "ioct/sim/replay_digitizer.hpp"
#include "ioct/sim/simulated_bench.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/sim/simulated_galvo_output.hpp"
#include "ioct/sim/simulated_lines.hpp"

#if IOCT_RT_HAVE_USB
#include "ioct/hal/usb/usb_digitizer.hpp"
#include "ioct/hal/usb/usb_galvo_output.hpp"
#include "ioct/hal/usb/usb_instrument.hpp"
#endif
#if IOCT_RT_HAVE_GPIO
#include "ioct/hal/gpio/gpiod_lines.hpp"
#endif

namespace ioct::rt {
namespace {

#if !IOCT_RT_HAVE_USB || !IOCT_RT_HAVE_GPIO
[[noreturn]] void not_built(const char* key, const std::string& value) {
  throw ConfigError(key, "\"" + value + "\"",
                    "is not built into this ioct-rt (its library was missing at build time); "
                    "use \"simulated\"");
}
#endif

}  // namespace

Backends make_backends(const RtSetup& setup) {
  const RtConfig& c = setup.config;
  Backends b;
  // One simulated bench behind whatever is simulated, so that the beam follows the galvo
  // output's mirrors, light reaches the sample only while emission is on, and injected faults
  // show everywhere.
  std::shared_ptr<sim::SimulatedBench> bench;
  if (c.digitizer_backend == "simulated" || c.galvo_backend == "simulated" ||
      c.lines_backend == "simulated") {
    bench = std::make_shared<sim::SimulatedBench>(setup.simulation.bench);
    b.bench = bench;
  }

  if (!setup.replay_file.empty()) {
    // A recording in place of the digitizer: the loop, the ring and the slot headers are the
    // live ones; the geometry must be the recording's (prepare() names both values).
    auto replay = std::make_unique<sim::ReplayDigitizer>(
        setup.replay_file, sim::ReplayOptions{.loop = setup.replay_loop, .bench = bench});
    const std::uint32_t recorded = replay->metadata().geometry.bscans_per_volume;
    if (recorded != setup.ring.geometry.bscans_per_volume) {
      throw ConfigError("scan.bscans_per_volume",
                        std::to_string(setup.ring.geometry.bscans_per_volume),
                        "the recording " + setup.replay_file + " has " + std::to_string(recorded));
    }
    b.digitizer = std::move(replay);
  } else if (c.digitizer_backend == "usb") {
#if IOCT_RT_HAVE_USB
    hal::usb::UsbInstrumentConfig usb;
    usb.vendor_id = static_cast<std::uint16_t>(c.usb_vendor_id);
    usb.product_id = static_cast<std::uint16_t>(c.usb_product_id);
    usb.serial = c.usb_serial;
    usb.validate();
    const std::shared_ptr<hal::usb::UsbInstrument> instrument = hal::usb::UsbInstrument::open(usb);
    b.digitizer = std::make_unique<hal::usb::UsbDigitizer>(instrument);
    if (c.galvo_backend == "usb") b.galvo = std::make_unique<hal::usb::UsbGalvoOutput>(instrument);
#else
    not_built("digitizer.backend", c.digitizer_backend);
#endif
  } else {
    b.digitizer = std::make_unique<sim::SimulatedDigitizer>(setup.simulation, bench);
  }
  if (!b.galvo) b.galvo = std::make_unique<sim::SimulatedGalvoOutput>(bench);

  if (c.lines_backend == "gpio") {
#if IOCT_RT_HAVE_GPIO
    b.lines = std::make_unique<hal::gpio::GpiodLines>();
#else
    not_built("lines.backend", c.lines_backend);
#endif
  } else {
    b.lines = std::make_unique<sim::SimulatedLines>(bench);
  }
  b.description = "digitizer " + std::string(b.digitizer->backend()) + ", galvo output " +
                  std::string(b.galvo->backend()) + ", lines " + std::string(b.lines->backend()) +
                  (bench ? " (simulated parts on one bench)" : "");
  return b;
}

}  // namespace ioct::rt
