#include "ioct/gpu/live_stages/processing_view_control.hpp"

#include <string>
#include <utility>

#include "ioct/common/config_error.hpp"
#include "ioct/common/strict_json.hpp"

namespace ioct::gpu::live {

namespace {

constexpr const char* kKey = "processing";

double db_value(const std::string& key, const nlohmann::json& value) {
  if (!value.is_number()) throw ConfigError(key, shown_json(value), "must be a number (dB)");
  return value.get<double>();
}

}  // namespace

ProcessingViewControl::ProcessingViewControl(ViewControl& views,
                                             std::function<DbScaleConfig()> db_range,
                                             std::function<void(const DbScaleConfig&)> set_db_range)
    : views_(views), db_range_(std::move(db_range)), set_db_range_(std::move(set_db_range)) {}

DbScaleConfig ProcessingViewControl::apply_processing_changes(const DbScaleConfig& base,
                                                              const nlohmann::json& changes) {
  if (!changes.is_object()) throw ConfigError(kKey, shown_json(changes), "must be an object");
  DbScaleConfig scale = base;
  for (const auto& [name, value] : changes.items()) {
    const std::string key = std::string(kKey) + "." + name;
    if (name == "db_min") {
      scale.db_min = db_value(key, value);
    } else if (name == "db_max") {
      scale.db_max = db_value(key, value);
    } else {
      throw ConfigError(key, shown_json(value), "is not a processing parameter (db_min, db_max)");
    }
  }
  scale.validate(kKey);
  return scale;
}

ViewParams ProcessingViewControl::params() const {
  ViewParams p = views_.params();
  const DbScaleConfig range = db_range_();
  p.params[kKey] = {{"db_min", range.db_min}, {"db_max", range.db_max}};
  return p;
}

std::uint64_t ProcessingViewControl::set_params(const nlohmann::json& changes) {
  const auto processing = changes.is_object() ? changes.find(kKey) : changes.end();
  if (processing == changes.end()) return views_.set_params(changes);
  std::lock_guard lock(mutex_);
  const DbScaleConfig scale = apply_processing_changes(db_range_(), *processing);
  nlohmann::json render_changes = changes;
  render_changes.erase(kKey);
  // The views' part may still be refused; the dB range is applied only once it is not. An
  // empty change still counts as one, so the viewers see the new generation.
  const std::uint64_t generation = views_.set_params(render_changes);
  set_db_range_(scale);
  return generation;
}

}  // namespace ioct::gpu::live
