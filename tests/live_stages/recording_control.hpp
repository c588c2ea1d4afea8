// A ViewControl for the view socket's tests: the parameters kept as a real RenderConfig (so the
// validation is the real one), the open views and the snapshots taken recorded. Thread-safe, as
// the socket calls it from its own thread.
#pragma once

#include <mutex>
#include <set>
#include <stdexcept>

#include "ioct/gpu/live_stages/view_control.hpp"
#include "ioct/gpu/render/render_params_json.hpp"

namespace ioct::gpu::live {

class RecordingControl final : public ViewControl {
 public:
  render::RenderConfig config;
  std::uint64_t generation = 1;
  std::set<std::uint64_t> open;
  int snapshots = 0;
  bool snapshot_fails = false;
  mutable std::mutex mutex;  // held by every call; tests on another thread take it to read

  ViewParams params() const override {
    std::lock_guard lock(mutex);
    return {generation, render::to_json(config)};
  }
  std::uint64_t set_params(const nlohmann::json& changes) override {
    std::lock_guard lock(mutex);
    config = render::apply_render_changes(config, changes);
    return ++generation;
  }
  std::uint64_t open_view(std::uint64_t view, const nlohmann::json& changes) override {
    std::lock_guard lock(mutex);
    if (open.size() >= 2 && !open.contains(view)) throw std::invalid_argument("too many views");
    (void)render::apply_camera_changes(config, changes);
    open.insert(view);
    return ++generation;
  }
  std::uint64_t set_view(std::uint64_t view, const nlohmann::json& changes) override {
    std::lock_guard lock(mutex);
    if (!open.contains(view)) throw std::out_of_range("not open");
    (void)render::apply_camera_changes(config, changes);
    return ++generation;
  }
  void close_view(std::uint64_t view) override {
    std::lock_guard lock(mutex);
    open.erase(view);
  }
  ViewSnapshot snapshot(std::chrono::milliseconds) override {
    std::lock_guard lock(mutex);
    if (snapshot_fails) throw std::runtime_error("nothing rendered yet");
    ++snapshots;
    ViewSnapshot shot;
    shot.image.resize(4, 3);
    shot.params = render::to_json(config);
    shot.generation = generation;
    shot.group_index = 42;
    return shot;
  }
};

}  // namespace ioct::gpu::live
