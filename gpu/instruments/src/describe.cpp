#include <cmath>
#include <cstdio>

#include "ioct/gpu/instruments/instrument_findings.hpp"

namespace ioct::gpu::instruments {

std::string_view to_string(DistanceSource source) noexcept {
  switch (source) {
    case DistanceSource::none:
      return "none";
    case DistanceSource::measured:
      return "measured";
    case DistanceSource::inferred:
      return "inferred";
  }
  return "unknown";
}

std::string describe(const InstrumentFindings& findings) {
  const InstrumentTip* tip = findings.nearest_tip();
  if (tip == nullptr) return "no instrument";
  char line[256];
  if (tip->source == DistanceSource::none) {
    std::snprintf(line, sizeof line, "tip (%.1f, %.1f, %.1f) vox, no retina under it", tip->bscan,
                  tip->ascan, tip->depth_px);
  } else {
    std::snprintf(line, sizeof line,
                  "tip (%.1f, %.1f, %.1f) vox: ILM %+.0f um, RPE %+.0f um (%s)%s", tip->bscan,
                  tip->ascan, tip->depth_px, tip->to_ilm_um, tip->to_rpe_um,
                  std::string(to_string(tip->source)).c_str(), findings.warning ? " WARNING" : "");
  }
  std::string out = line;
  if (findings.tips.size() > 1) out += " (+" + std::to_string(findings.tips.size() - 1) + " more)";
  return out;
}

}  // namespace ioct::gpu::instruments
