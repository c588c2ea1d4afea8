#include "ioct/sim/instrument_spec.hpp"

#include <map>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/common/input_file.hpp"

namespace ioct::sim {
namespace {

[[noreturn]] void bad(const std::string& key, std::string_view value, const std::string& allowed) {
  throw ConfigError(key, "'" + quote_input(value, 80) + "'", allowed);
}

float number(const std::string& key, const std::string& text) {
  try {
    std::size_t used = 0;
    const double value = std::stod(text, &used);
    if (used == text.size()) return static_cast<float>(value);
  } catch (const std::exception&) {
  }
  bad(key, text, "must be a number");
}

}  // namespace

InstrumentConfig parse_instrument_spec(std::string_view spec, const std::string& key) {
  const std::size_t colon = spec.find(':');
  const std::string_view kind = spec.substr(0, colon);
  InstrumentConfig tool;
  if (kind == "forceps") {
    tool.kind = InstrumentKind::forceps;
  } else if (kind == "needle") {
    tool.kind = InstrumentKind::needle;
  } else if (kind == "scraper") {
    tool.kind = InstrumentKind::scraper;
  } else {
    bad(key, kind, "must start with forceps, needle or scraper");
  }
  if (colon == std::string_view::npos) return tool;
  const std::string rest(spec.substr(colon + 1));
  std::size_t at = 0;
  while (at <= rest.size()) {
    const std::size_t comma = rest.find(',', at);
    const std::string item =
        rest.substr(at, comma == std::string::npos ? std::string::npos : comma - at);
    at = comma == std::string::npos ? rest.size() + 1 : comma + 1;
    if (item.empty()) continue;
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos) bad(key, item, "items are name=value");
    const std::string name = item.substr(0, eq);
    const float value = number(key + "." + quote_input(name, 20), item.substr(eq + 1));
    const std::map<std::string, float*> fields{
        {"x", &tool.pose.tip_x},
        {"y", &tool.pose.tip_y},
        {"depth", &tool.pose.tip_depth_fraction},
        {"yaw", &tool.pose.yaw_deg},
        {"pitch", &tool.pose.pitch_deg},
        {"open", &tool.pose.jaw_opening_deg},
        {"vx", &tool.motion.velocity_x},
        {"vy", &tool.motion.velocity_y},
        {"vdepth", &tool.motion.velocity_depth},
        {"tremor", &tool.motion.tremor_x},
        {"tremor-depth", &tool.motion.tremor_depth},
        {"tremor-hz", &tool.motion.tremor_hz},
        {"jaw-cycle", &tool.motion.jaw_cycle_deg},
        {"jaw-hz", &tool.motion.jaw_cycle_hz},
    };
    const auto field = fields.find(name);
    if (field == fields.end()) {
      bad(key + "." + quote_input(name, 20), item,
          "known names: " + std::string(kInstrumentSpecNames));
    }
    *field->second = value;
    if (name == "tremor") tool.motion.tremor_y = value;  // lateral tremor: both axes alike
  }
  return tool;
}

}  // namespace ioct::sim
