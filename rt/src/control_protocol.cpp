#include "control_protocol.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <set>
#include <utility>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/common/input_file.hpp"
#include "ioct/common/strict_json.hpp"

namespace ioct::rt {
namespace {

constexpr std::array<std::pair<ControlVerb, std::string_view>, 4> kVerbs{{
    {ControlVerb::status, "status"},
    {ControlVerb::start, "start"},
    {ControlVerb::stop, "stop"},
    {ControlVerb::scan, "scan"},
}};

// The JSON value as a short text for error messages.
std::string shown(const nlohmann::json& value) {
  std::string text = value.dump(-1, ' ', true, nlohmann::json::error_handler_t::replace);
  if (text.size() > 64) text = text.substr(0, 61) + "...";
  return text;
}

double number(const nlohmann::json& value, const std::string& key) {
  if (!value.is_number()) {
    throw ConfigError(key, shown(value), "must be a number");
  }
  return value.get<double>();
}

std::uint32_t count(const nlohmann::json& value, const std::string& key, std::uint64_t lo,
                    std::uint64_t hi) {
  if (!value.is_number_integer()) throw ConfigError(key, shown(value), "must be an integer");
  if (value.is_number_unsigned()) {
    const std::uint64_t v = value.get<std::uint64_t>();
    require_integer_in_range(key, v, lo, hi);
    return static_cast<std::uint32_t>(v);
  }
  const std::int64_t v = value.get<std::int64_t>();
  if (v < 0) {
    throw ConfigError(key, format_value(v),
                      "must be in [" + format_value(lo) + ", " + format_value(hi) + "]");
  }
  require_integer_in_range(key, static_cast<std::uint64_t>(v), lo, hi);
  return static_cast<std::uint32_t>(v);
}

}  // namespace

std::string_view to_string(ControlVerb verb) noexcept {
  for (const auto& [v, name] : kVerbs) {
    if (v == verb) return name;
  }
  return "unknown";
}

std::variant<ControlRequest, ControlParseError> parse_control_line(std::string_view line) {
  if (line.size() > kMaxControlLineBytes) {
    return ControlParseError{"line longer than " + std::to_string(kMaxControlLineBytes) + " bytes",
                             nullptr};
  }
  if (line.find_first_not_of(" \t\r") == std::string_view::npos) {
    return ControlParseError{"empty line: expected one JSON object, like {\"cmd\": \"status\"}",
                             nullptr};
  }
  StrictJson parsed = parse_json_strictly(line);
  nlohmann::json& doc = parsed.value;
  if (doc.is_discarded()) {
    return ControlParseError{
        "not valid JSON: expected one object per line, like {\"cmd\": \"status\"}", nullptr};
  }
  if (!parsed.duplicate_key.empty()) {
    return ControlParseError{"key \"" + quote_input(parsed.duplicate_key, 40) +
                                 "\" given twice in one object; each key once",
                             nullptr};
  }
  if (!doc.is_object()) {
    return ControlParseError{"expected a JSON object, got " + std::string(doc.type_name()),
                             nullptr};
  }
  ControlRequest request;
  if (const auto id = doc.find("id"); id != doc.end()) request.id = *id;
  const auto cmd = doc.find("cmd");
  if (cmd == doc.end()) {
    return ControlParseError{"missing \"cmd\"; verbs: status, start, stop, scan", request.id};
  }
  if (!cmd->is_string()) {
    return ControlParseError{"\"cmd\" must be a string, not " + std::string(cmd->type_name()),
                             request.id};
  }
  const std::string verb = cmd->get<std::string>();
  bool known = false;
  for (const auto& [v, name] : kVerbs) {
    if (name == verb) {
      request.verb = v;
      known = true;
    }
  }
  if (!known) {
    return ControlParseError{"unknown verb " + shown(*cmd) + "; verbs: status, start, stop, scan",
                             request.id};
  }
  for (const auto& [key, value] : doc.items()) {
    if (key == "cmd" || key == "id") continue;
    if (key == "scan" && request.verb == ControlVerb::scan) continue;
    return ControlParseError{
        "unexpected member " + shown(nlohmann::json(key)) + " in a \"" + verb + "\" command",
        request.id};
  }
  if (request.verb == ControlVerb::scan) {
    const auto scan = doc.find("scan");
    if (scan == doc.end() || !scan->is_object()) {
      return ControlParseError{
          "a scan command needs a \"scan\" object, e.g. {\"cmd\": \"scan\", \"scan\": "
          "{\"pattern\": \"radial\"}}",
          request.id};
    }
    request.scan_changes = *scan;
  }
  return request;
}

scan::ScanSpec apply_scan_changes(const scan::ScanSpec& base, const nlohmann::json& changes) {
  scan::ScanSpec spec = base;
  for (const auto& [member, value] : changes.items()) {
    const std::string key = "scan." + member;
    if (member == "pattern") {
      if (!value.is_string()) throw ConfigError(key, shown(value), "must be a string");
      const std::optional<scan::ScanKind> kind =
          scan::scan_kind_from_string(value.get<std::string>());
      if (!kind) {
        throw ConfigError(key, shown(value),
                          "must be one of raster, bidirectional, crosshair, radial");
      }
      spec.kind = *kind;
    } else if (member == "repeats") {
      spec.repeats = count(value, key, 1, 65536);
    } else if (member == "inactive_ascans") {
      spec.inactive_ascans = count(value, key, 0, 32767);
    } else if (member == "extent_x") {
      spec.extent_x = number(value, key);
    } else if (member == "extent_y") {
      spec.extent_y = number(value, key);
    } else if (member == "offset_x") {
      spec.offset_x = number(value, key);
    } else if (member == "offset_y") {
      spec.offset_y = number(value, key);
    } else if (member == "rotation_deg") {
      spec.rotation_deg = number(value, key);
    } else if (member == "bscans_per_volume") {
      throw ConfigError(key, shown(value),
                        "is fixed by the ring's geometry while ioct-rt runs; restart with another "
                        "configuration to change it");
    } else {
      const std::string quoted = shown(nlohmann::json(member));  // escaped, shortened
      throw ConfigError("scan." + quoted.substr(1, quoted.size() - 2), shown(value),
                        "unknown scan key; a scan change takes pattern, repeats, extent_x, "
                        "extent_y, offset_x, offset_y, rotation_deg, inactive_ascans");
    }
  }
  spec.validate();
  return spec;
}

}  // namespace ioct::rt
