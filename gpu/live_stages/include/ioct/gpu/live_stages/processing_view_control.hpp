// The live view's parameters as the viewers see them: the render parameters of the views
// (VolumeStages) plus the processing's one control, the dB range ("processing": {"db_min",
// "db_max"}), which the live loop applies from its next group. A change naming both kinds is
// checked whole before any of it is applied.
#pragma once

#include <functional>
#include <mutex>

#include "ioct/gpu/live_stages/view_control.hpp"
#include "ioct/gpu/processing/db_scale.hpp"

namespace ioct::gpu::live {

class ProcessingViewControl final : public ViewControl {
 public:
  // The range lives with the processing (LiveProcessor::db_range / set_db_range): `db_range`
  // reads it, `set_db_range` hands it a validated new one.
  ProcessingViewControl(ViewControl& views, std::function<DbScaleConfig()> db_range,
                        std::function<void(const DbScaleConfig&)> set_db_range);

  ViewParams params() const override;
  std::uint64_t set_params(const nlohmann::json& changes) override;
  std::uint64_t open_view(std::uint64_t view, const nlohmann::json& changes) override {
    return views_.open_view(view, changes);
  }
  std::uint64_t set_view(std::uint64_t view, const nlohmann::json& changes) override {
    return views_.set_view(view, changes);
  }
  void close_view(std::uint64_t view) override { views_.close_view(view); }
  ViewSnapshot snapshot(std::chrono::milliseconds timeout) override {
    return views_.snapshot(timeout);
  }

  // `changes`' "processing" object applied to `base` (ConfigError naming
  // "processing.<key>"; unknown keys and wrong types too).
  static DbScaleConfig apply_processing_changes(const DbScaleConfig& base,
                                                const nlohmann::json& changes);

 private:
  ViewControl& views_;
  std::function<DbScaleConfig()> db_range_;
  std::function<void(const DbScaleConfig&)> set_db_range_;
  std::mutex mutex_;  // one change at a time (a change reads the range, then sets it)
};

}  // namespace ioct::gpu::live
