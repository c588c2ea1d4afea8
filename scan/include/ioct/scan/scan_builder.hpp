// Plans a scan pattern: lays out the lines of one volume for the pattern kind, maps them into
// the field (extent, rotation, offset), joins consecutive lines with quintic transitions during
// the flyback sweeps, and checks the result against the field and the galvo's limits.
#pragma once

#include "ioct/hal/digitizer_config.hpp"
#include "ioct/hal/raster_scan.hpp"
#include "ioct/scan/scan_pattern.hpp"
#include "ioct/scan/scan_spec.hpp"

namespace ioct::scan {

// Throws ConfigError ("scan.<key>") when the spec does not fit the timing (repeats that do not
// divide the volume, too many inactive A-scans, ...), and ScanInfeasible when the mirrors would
// leave the field or exceed a limit: the message names the limit, the B-scan and axis, the value
// required against the one allowed, the excess in percent, and the fewest flyback sweeps that
// would do where more flyback time helps.
ScanPattern build_scan_pattern(const ScanSpec& spec, const ScanTiming& timing,
                               const GalvoLimits& limits);

// A raster (or bidirectional raster) over the field of a hal::RasterScan, the lines the
// simulator's ideal beam takes, planned for the digitizer's timing: what a driven galvo of the
// simulator's tools follows, so that it and the ideal beam place each recorded A-scan alike.
// Throws ConfigError when the field's A-scans per B-scan are not the digitizer's, else as
// build_scan_pattern().
ScanPattern plan_raster(const hal::RasterScan& field, const hal::DigitizerConfig& digitizer,
                        ScanKind kind, const GalvoLimits& limits);

}  // namespace ioct::scan
