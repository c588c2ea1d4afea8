// The findings as JSON for summary.json and the view socket's "instruments" request: per tip its
// voxels, um, distances (null where unknown) and their source; the warning; the shadowed A-scans.
#pragma once

#include <nlohmann/json.hpp>

#include "ioct/gpu/instruments/instrument_findings.hpp"

namespace ioct::gpu::instruments {

nlohmann::json to_json(const InstrumentFindings& findings);

}  // namespace ioct::gpu::instruments
