#include "ioct/gpu/instruments/findings_json.hpp"

#include <cmath>
#include <string>

namespace ioct::gpu::instruments {
namespace {

nlohmann::json number(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

}  // namespace

nlohmann::json to_json(const InstrumentFindings& findings) {
  std::size_t shadowed = 0, partial = 0;
  for (const ColumnKind k : findings.mask) {
    shadowed += k == ColumnKind::shadow ? 1 : 0;
    partial += k == ColumnKind::partial ? 1 : 0;
  }
  nlohmann::json tips = nlohmann::json::array();
  for (const InstrumentTip& t : findings.tips) {
    tips.push_back({{"voxel", {number(t.bscan), number(t.ascan), number(t.depth_px)}},
                    {"um", {number(t.x_um), number(t.y_um), number(t.z_um)}},
                    {"axis", {number(t.axis_x), number(t.axis_y)}},
                    {"to_ilm_um", number(t.to_ilm_um)},
                    {"to_rpe_um", number(t.to_rpe_um)},
                    {"distance", std::string(to_string(t.source))},
                    {"translucent", t.translucent},
                    {"footprint_ascans", t.footprint_ascans}});
  }
  return {{"tips", tips},
          {"nearest",
           findings.nearest >= 0 ? nlohmann::json(findings.nearest) : nlohmann::json(nullptr)},
          {"warning", findings.warning},
          {"shadowed_ascans", shadowed},
          {"partly_shadowed_ascans", partial},
          {"summary", describe(findings)}};
}

}  // namespace ioct::gpu::instruments
