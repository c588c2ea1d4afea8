#include "ioct/hal/raster_scan.hpp"

#include <cmath>

#include "ioct/common/config_error.hpp"

namespace ioct::hal {

void RasterScan::validate() const {
  require_integer_in_range("scan.ascans_per_bscan", ascans_per_bscan, 1, 65536);
  require_integer_in_range("scan.bscans_per_volume", bscans_per_volume, 1, 65536);
  require_real_in_range("scan.extent_x", extent_x, 0.0, 1.0);
  require_real_in_range("scan.extent_y", extent_y, 0.0, 1.0);
  require_real_in_range("scan.center_x", center_x, -1.0, 1.0);
  require_real_in_range("scan.center_y", center_y, -1.0, 1.0);
  if (std::fabs(center_x) + extent_x > 1.0f) {
    throw ConfigError("scan.extent_x", format_value(double{extent_x}),
                      "the line about center_x = " + format_value(double{center_x}) +
                          " must stay within [-1, 1]");
  }
  if (std::fabs(center_y) + extent_y > 1.0f) {
    throw ConfigError("scan.extent_y", format_value(double{extent_y}),
                      "the volume about center_y = " + format_value(double{center_y}) +
                          " must stay within [-1, 1]");
  }
}

}  // namespace ioct::hal
