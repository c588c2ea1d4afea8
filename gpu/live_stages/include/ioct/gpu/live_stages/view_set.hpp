// The views the live stages render and when each one is due: the shared (operator's) view 0 with
// the render parameters, and the viewers' private views, each the shared parameters with a camera
// of its own. A view is due after a pass (the volume changed), after a change of its parameters,
// at the frame rate while it auto-rotates, and once more at full size when it stops moving if it
// was rendered reduced while it moved (the CPU renderer cannot keep up at full size).
//
// Not thread-safe: VolumeStages guards it with its mutex. Times are CLOCK_MONOTONIC ns.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include <nlohmann/json.hpp>

#include "ioct/gpu/render/render_config.hpp"

namespace ioct::gpu::live {

inline constexpr std::uint64_t kSharedView = 0;

struct ViewTiming {
  double frame_rate_hz = 60.0;       // at most this many renders of one view per second
  bool reduce_while_moving = false;  // render at moving_scale while the view moves (CPU)
  double moving_scale = 0.5;
  double settle_s = 0.3;  // a view changed this recently still moves
};

// One render to do: which view, with which parameters (the azimuth as of now).
struct DueRender {
  std::uint64_t view_id = kSharedView;
  render::RenderConfig config;
  std::uint64_t generation = 0;
  bool reduced = false;
};

class ViewSet {
 public:
  ViewSet(render::RenderConfig shared, ViewTiming timing, std::uint64_t now_ns);

  // The renderer is known only once the stages' thread made it.
  void set_timing(const ViewTiming& timing) { timing_ = timing; }
  std::uint64_t generation() const noexcept { return generation_; }
  // The shared view's parameters, the azimuth as of now.
  render::RenderConfig shared(std::uint64_t now_ns) const;

  // Each throws ConfigError (render_params_json) and changes nothing on a bad change; each returns
  // the new generation. A change of the azimuth turns the view from where it is now.
  std::uint64_t set_shared(const nlohmann::json& changes, std::uint64_t now_ns);
  // Opens (or reopens) private view `id` (not kSharedView) at the shared camera, then `changes`
  // (camera only). std::invalid_argument for id 0 or more than max_private views.
  std::uint64_t open(std::uint64_t id, const nlohmann::json& changes, std::uint64_t now_ns);
  // std::out_of_range for a view that is not open.
  std::uint64_t set_camera(std::uint64_t id, const nlohmann::json& changes, std::uint64_t now_ns);
  void close(std::uint64_t id);
  bool is_open(std::uint64_t id) const { return views_.contains(id); }
  std::size_t private_views() const noexcept { return views_.size() - 1; }

  // The volume changed: every private view is due (the caller renders the shared one at once
  // with take_shared).
  void volume_changed();
  // The shared view's next render is due, at full size (a snapshot waits for it).
  void want_full_shared();

  // The views due now, as they are to be rendered; they count as rendered from now.
  std::vector<DueRender> take_due(std::uint64_t now_ns);
  // The shared view as it is to be rendered now, whether due or not; it counts as rendered.
  DueRender take_shared(std::uint64_t now_ns);
  // Until when nothing falls due by itself (the next auto-rotation frame or full-size render);
  // UINT64_MAX when only a change or a pass can make a view due.
  std::uint64_t next_due_ns(std::uint64_t now_ns) const;

  static constexpr std::size_t kMaxPrivateViews = 16;

 private:
  struct View {
    render::ViewConfig camera;  // private views: their own; the shared one: unused
    std::uint64_t rotation_origin_ns = 0;
    std::uint64_t last_change_ns = 0;
    std::uint64_t last_render_ns = 0;
    bool due = false;
    bool rendered = false;
    bool last_reduced = false;
    bool force_full = false;
  };

  render::RenderConfig config_of(const View& view, std::uint64_t id, std::uint64_t now_ns) const;
  // Where the azimuth is now, folded into the camera (so a change turns from there).
  void settle_rotation(View& view, render::ViewConfig& camera, std::uint64_t now_ns) const;
  bool moving(const View& view, const render::ViewConfig& camera, std::uint64_t now_ns) const;
  std::uint64_t frame_period_ns() const;

  render::RenderConfig shared_;
  ViewTiming timing_;
  std::map<std::uint64_t, View> views_;  // kSharedView always present
  std::uint64_t generation_ = 1;
};

}  // namespace ioct::gpu::live
