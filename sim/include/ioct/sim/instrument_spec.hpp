// An instrument in one line of text, as the command line and the configuration give it:
//   "forceps:x=0.1,y=0,depth=0.4,yaw=180,pitch=25,open=20,vx=0.05,tremor=0.01"
// the kind (forceps, needle, scraper), then name=value items for its pose and motion
// (InstrumentConfig). One parser for ioct-sim-record's --tool and ioct-rt's simulated scene.
#pragma once

#include <string>
#include <string_view>

#include "ioct/sim/instrument_model.hpp"

namespace ioct::sim {

// Throws ioct::ConfigError naming `key` (e.g. "--tool[0]" or "simulation.instruments[1]"), the
// item and what is allowed. Ranges are checked by InstrumentConfig::validate, not here.
InstrumentConfig parse_instrument_spec(std::string_view spec, const std::string& key);

// The names an item may take, for help texts and messages.
inline constexpr std::string_view kInstrumentSpecNames =
    "x, y, depth, yaw, pitch, open, vx, vy, vdepth, tremor, tremor-depth, tremor-hz, jaw-cycle, "
    "jaw-hz";

}  // namespace ioct::sim
