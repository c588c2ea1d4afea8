// The control channel's language: one JSON object per line in, one per line out.
//
//   {"cmd": "status"}                       → {"ok": true, "cmd": "status", "status": {...}}
//   {"cmd": "start"}   {"cmd": "stop"}      → {"ok": true, "cmd": "start", "state": "arming"}
//   {"cmd": "scan", "scan": {"pattern": "radial", "extent_x": 0.5}}
//                                           → {"ok": true, "cmd": "scan", "generation": ...}
//   anything else                           → {"ok": false, "error": "<what is wrong>"}
// An "id" member (any JSON value) is echoed in the reply. Parsing is pure; the server and the
// process decide what the verbs do.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <variant>

#include "ioct/common/line_server.hpp"
#include "ioct/scan/scan_spec.hpp"

namespace ioct::rt {

using ioct::error_reply;
using ioct::kMaxControlLineBytes;

enum class ControlVerb { status, start, stop, scan };
std::string_view to_string(ControlVerb verb) noexcept;

struct ControlRequest {
  ControlVerb verb = ControlVerb::status;
  nlohmann::json id;            // null when absent
  nlohmann::json scan_changes;  // the "scan" object of a scan command
};

struct ControlParseError {
  std::string message;
  nlohmann::json id;  // echoed when the line had one
};

// Parses one line (without its newline). Never throws.
std::variant<ControlRequest, ControlParseError> parse_control_line(std::string_view line);

// `base` with the members of `changes` applied (pattern, repeats, extent_x, extent_y, offset_x,
// offset_y, rotation_deg, inactive_ascans) and validated. Throws ConfigError naming "scan.<key>"
// for an unknown key, a wrong type or a value out of range.
scan::ScanSpec apply_scan_changes(const scan::ScanSpec& base, const nlohmann::json& changes);

}  // namespace ioct::rt
