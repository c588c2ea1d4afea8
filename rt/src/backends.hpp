// The hardware behind ioct-rt, chosen by the configuration's backend keys: the digitizer, the
// galvo output and the lines, constructed (not yet prepared). "simulated" is the simulator's
// bench (sim/): the three share it, as the real ones share the instrument and the laser.
#pragma once

#include <memory>
#include <string>

#include "ioct/hal/digitizer.hpp"
#include "ioct/hal/galvo_output.hpp"
#include "ioct/hal/lines.hpp"
#include "rt_options.hpp"

namespace ioct::rt {

struct Backends {
  std::unique_ptr<hal::Digitizer> digitizer;
  std::unique_ptr<hal::GalvoOutput> galvo;
  std::unique_ptr<hal::Lines> lines;
  std::shared_ptr<void> bench;  // the simulated bench the three share, when simulated
  std::string description;
};

// Throws ConfigError naming the backend key when this build has no such backend.
Backends make_backends(const RtSetup& setup);

}  // namespace ioct::rt
