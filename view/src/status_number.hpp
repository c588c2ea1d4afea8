// A figure read from another process's JSON status (ioct-rt's, ioct-record's) for /metrics: a
// number, or a boolean as 0/1; nullopt when absent or of another type, so the metric is left out
// rather than shown as 0.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>

namespace ioct::view {

inline std::optional<double> status_number(const nlohmann::json& object, const char* key) {
  if (!object.is_object()) return std::nullopt;
  const auto it = object.find(key);
  if (it == object.end()) return std::nullopt;
  if (it->is_boolean()) return it->get<bool>() ? 1.0 : 0.0;
  if (it->is_number()) return it->get<double>();
  return std::nullopt;
}

}  // namespace ioct::view
