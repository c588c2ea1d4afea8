#include "ioct/gpu/live/processing_view_control.hpp"

#include <string>
#include <utility>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu::live {

namespace {

constexpr const char* kKey = "processing";

std::string shown(const nlohmann::json& value) {
  constexpr std::size_t kShown = 40;
  std::string text = value.dump();
  if (text.size() > kShown) text = text.substr(0, kShown) + "...";
  return text;
}

double db_value(const std::string& key, const nlohmann::json& value) {
  if (!value.is_number()) throw ConfigError(key, shown(value), "must be a number (dB)");
  return value.get<double>();
}

}  // namespace

ProcessingViewControl::ProcessingViewControl(ViewControl& views, DbScaleConfig initial,
                                             std::function<void(const DbScaleConfig&)> set_db_range)
    : views_(views), set_db_range_(std::move(set_db_range)), db_range_(initial) {}

DbScaleConfig ProcessingViewControl::apply_processing_changes(const DbScaleConfig& base,
                                                              const nlohmann::json& changes) {
  if (!changes.is_object()) throw ConfigError(kKey, shown(changes), "must be an object");
  DbScaleConfig scale = base;
  for (const auto& [name, value] : changes.items()) {
    const std::string key = std::string(kKey) + "." + name;
    if (name == "db_min") {
      scale.db_min = db_value(key, value);
    } else if (name == "db_max") {
      scale.db_max = db_value(key, value);
    } else {
      throw ConfigError(key, shown(value), "is not a processing parameter (db_min, db_max)");
    }
  }
  require_real_in_range(std::string(kKey) + ".db_min", scale.db_min, -200.0, 300.0);
  require_real_in_range(std::string(kKey) + ".db_max", scale.db_max, -200.0, 300.0);
  if (!(scale.db_max - scale.db_min >= 1.0)) {
    throw ConfigError(std::string(kKey) + ".db_max", format_value(scale.db_max),
                      "must be at least 1 dB above db_min (" + format_value(scale.db_min) + ")");
  }
  return scale;
}

ViewParams ProcessingViewControl::params() const {
  ViewParams p = views_.params();
  std::lock_guard lock(mutex_);
  p.params[kKey] = {{"db_min", db_range_.db_min}, {"db_max", db_range_.db_max}};
  return p;
}

std::uint64_t ProcessingViewControl::set_params(const nlohmann::json& changes) {
  const auto processing = changes.is_object() ? changes.find(kKey) : changes.end();
  if (processing == changes.end()) return views_.set_params(changes);
  std::lock_guard lock(mutex_);
  const DbScaleConfig scale = apply_processing_changes(db_range_, *processing);
  nlohmann::json render_changes = changes;
  render_changes.erase(kKey);
  // The views' part may still be refused; the dB range is applied only once it is not. An
  // empty change still counts as one, so the viewers see the new generation.
  const std::uint64_t generation = views_.set_params(render_changes);
  set_db_range_(scale);
  db_range_ = scale;
  return generation;
}

}  // namespace ioct::gpu::live
