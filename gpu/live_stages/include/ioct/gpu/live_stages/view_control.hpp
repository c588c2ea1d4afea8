// What viewers may ask of the live view, whoever carries the request (the view socket, tests):
// read and change the render parameters, open, steer and close a private view, take a snapshot.
// Implemented by VolumeStages; every call is thread-safe and returns without waiting for a render,
// except snapshot(), which waits for the next frame of the shared view.
#pragma once

#include <chrono>
#include <cstdint>

#include <nlohmann/json.hpp>

#include "ioct/gpu/render/rgba_image.hpp"

namespace ioct::gpu::live {

struct ViewParams {
  std::uint64_t generation = 0;  // grows with every change of any view
  nlohmann::json params;         // render_params_json's to_json of the shared view
};

struct ViewSnapshot {
  render::RgbaImage image;  // the shared view's frame, full size
  nlohmann::json params;    // the parameters it was rendered with
  std::uint64_t generation = 0;
  std::uint64_t group_index = 0;  // the newest group in the volume it shows
};

class ViewControl {
 public:
  virtual ~ViewControl() = default;
  virtual ViewParams params() const = 0;
  // Each throws ConfigError for a bad change (naming the key) and changes nothing then; each
  // returns the new generation.
  virtual std::uint64_t set_params(const nlohmann::json& changes) = 0;
  // Also std::invalid_argument (view 0, too many views).
  virtual std::uint64_t open_view(std::uint64_t view, const nlohmann::json& changes) = 0;
  // Also std::out_of_range for a view that is not open.
  virtual std::uint64_t set_view(std::uint64_t view, const nlohmann::json& changes) = 0;
  virtual void close_view(std::uint64_t view) = 0;
  // The shared view's next frame, rendered after this call. Throws std::runtime_error when there
  // is nothing to render yet, the stages stopped, or no frame came within `timeout`.
  virtual ViewSnapshot snapshot(std::chrono::milliseconds timeout) = 0;
  // The instruments found in the live volume (gpu/instruments' findings JSON with "enabled"),
  // or {"enabled": false} where the detection does not run.
  virtual nlohmann::json instruments() const { return {{"enabled", false}}; }
};

}  // namespace ioct::gpu::live
