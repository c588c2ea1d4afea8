#include "instrument_metrics.hpp"

#include <cmath>

#include "prometheus_text.hpp"

namespace ioct::view {

void write_instrument_metrics(const shm::FrameInstrument& in, bool gpu_up, std::string& out) {
  const auto state = static_cast<shm::FrameInstrumentState>(in.state);
  if (!gpu_up || state == shm::FrameInstrumentState::off) return;
  const bool found = state == shm::FrameInstrumentState::found;
  prom::single(out, "ioct_instrument_found", "gauge",
               "1 while the newest frame shows an instrument, 0 when detection found none",
               found ? 1 : 0);
  if (!found) return;
  prom::single(out, "ioct_instrument_warning", "gauge",
               "1 while the tip is within the warning distance of the RPE",
               in.warning != 0 ? 1 : 0);
  const auto source = static_cast<shm::FrameDistanceSource>(in.distance_source);
  prom::single(out, "ioct_instrument_distance_inferred", "gauge",
               "1 when the surfaces at the tip were carried in from beside the tool's shadow, 0 "
               "when measured there",
               source == shm::FrameDistanceSource::inferred ? 1 : 0);
  // Unknown distances (no segmented surface near the tip) are left out, not written as 0.
  if (std::isfinite(in.to_rpe_um)) {
    prom::single(out, "ioct_instrument_tip_to_rpe_meters", "gauge",
                 "signed distance from the tip to the RPE, positive above it",
                 static_cast<double>(in.to_rpe_um) * 1e-6);
  }
  if (std::isfinite(in.to_ilm_um)) {
    prom::single(out, "ioct_instrument_tip_to_ilm_meters", "gauge",
                 "signed distance from the tip to the ILM, positive above it",
                 static_cast<double>(in.to_ilm_um) * 1e-6);
  }
}

}  // namespace ioct::view
