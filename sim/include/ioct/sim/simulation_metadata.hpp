// What a recording of simulated groups says about itself: the digitizer geometry, the
// calibration (resampling polynomial, dispersion) and the whole simulation config as provenance.
#pragma once

#include <nlohmann/json.hpp>

#include "ioct/recording/recording_format.hpp"
#include "ioct/sim/simulation_config.hpp"

namespace ioct::sim {

class SimulatedDigitizer;

// The simulation config as JSON (the recording's "acquisition" object).
nlohmann::json to_json(const SimulationConfig& simulation);

// Metadata for recording a prepared simulated digitizer's groups, with ground truth.
recording::RecordingMetadata recording_metadata(const SimulatedDigitizer& digitizer);

}  // namespace ioct::sim
