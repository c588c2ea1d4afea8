#include "ioct/gpu/live_stages/view_set.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/gpu/render/render_params_json.hpp"

namespace ioct::gpu::live {
namespace {

constexpr std::uint64_t kNever = UINT64_MAX;

// The output at `scale` of its size (the same picture, fewer rays).
void shrink(render::ViewConfig& view, double scale) {
  const auto scaled = [&](std::uint32_t px) {
    return std::max<std::uint32_t>(1, static_cast<std::uint32_t>(std::lround(px * scale)));
  };
  view.output_width = scaled(view.output_width);
  view.output_height = scaled(view.output_height);
}

}  // namespace

ViewSet::ViewSet(render::RenderConfig shared, ViewTiming timing, std::uint64_t now_ns)
    : shared_(std::move(shared)), timing_(timing) {
  View& view = views_[kSharedView];
  view.rotation_origin_ns = now_ns;
}

std::uint64_t ViewSet::frame_period_ns() const {
  return timing_.frame_rate_hz > 0.0 ? seconds_to_ns(1.0 / timing_.frame_rate_hz) : 0;
}

render::RenderConfig ViewSet::config_of(const View& view, std::uint64_t id,
                                        std::uint64_t now_ns) const {
  render::RenderConfig config = shared_;
  if (id != kSharedView) config.view = view.camera;
  render::ViewConfig& camera = config.view;
  if (camera.auto_rotate && now_ns > view.rotation_origin_ns) {
    const double seconds = static_cast<double>(now_ns - view.rotation_origin_ns) * 1e-9;
    camera.azimuth_deg = std::fmod(camera.azimuth_deg + camera.rotation_deg_per_s * seconds, 360.0);
  }
  return config;
}

render::RenderConfig ViewSet::shared(std::uint64_t now_ns) const {
  return config_of(views_.at(kSharedView), kSharedView, now_ns);
}

bool ViewSet::moving(const View& view, const render::ViewConfig& camera,
                     std::uint64_t now_ns) const {
  if (camera.auto_rotate && camera.rotation_deg_per_s != 0.0) return true;
  return now_ns < view.last_change_ns + seconds_to_ns(timing_.settle_s);
}

std::uint64_t ViewSet::set_shared(const nlohmann::json& changes, std::uint64_t now_ns) {
  View& view = views_.at(kSharedView);
  // From where the view has turned to, so switching the rotation off keeps the picture still.
  render::RenderConfig changed =
      render::apply_render_changes(config_of(view, kSharedView, now_ns), changes);
  shared_ = std::move(changed);
  view.rotation_origin_ns = now_ns;
  view.last_change_ns = now_ns;
  for (auto& [id, v] : views_) v.due = true;  // private views share every other parameter
  return ++generation_;
}

std::uint64_t ViewSet::open(std::uint64_t id, const nlohmann::json& changes, std::uint64_t now_ns) {
  if (id == kSharedView) throw std::invalid_argument("view 0 is the shared view");
  if (!views_.contains(id) && private_views() >= kMaxPrivateViews) {
    throw std::invalid_argument("at most " + std::to_string(kMaxPrivateViews) +
                                " private views are open at once");
  }
  const render::RenderConfig start = shared(now_ns);
  View view;
  view.camera = render::apply_camera_changes(start, changes).view;
  view.rotation_origin_ns = now_ns;
  view.last_change_ns = now_ns;
  view.due = true;
  views_[id] = view;
  return ++generation_;
}

std::uint64_t ViewSet::set_camera(std::uint64_t id, const nlohmann::json& changes,
                                  std::uint64_t now_ns) {
  const auto it = id == kSharedView ? views_.end() : views_.find(id);
  if (it == views_.end()) throw std::out_of_range("view " + std::to_string(id) + " is not open");
  View& view = it->second;
  view.camera = render::apply_camera_changes(config_of(view, id, now_ns), changes).view;
  view.rotation_origin_ns = now_ns;
  view.last_change_ns = now_ns;
  view.due = true;
  return ++generation_;
}

void ViewSet::close(std::uint64_t id) {
  if (id != kSharedView) views_.erase(id);
}

void ViewSet::volume_changed() {
  for (auto& [id, view] : views_) {
    if (id != kSharedView) view.due = true;
  }
}

void ViewSet::want_full_shared() {
  View& view = views_.at(kSharedView);
  view.due = true;
  view.force_full = true;
}

std::uint64_t ViewSet::next_due_ns(std::uint64_t now_ns) const {
  const std::uint64_t period = frame_period_ns();
  std::uint64_t next = kNever;
  for (const auto& [id, view] : views_) {
    const render::ViewConfig camera = config_of(view, id, now_ns).view;
    const std::uint64_t allowed = view.rendered ? view.last_render_ns + period : 0;
    std::uint64_t when = kNever;
    if (view.due) {
      when = allowed;
    } else if (!view.rendered) {
      continue;  // nothing to show yet: the first pass makes it due
    } else if (camera.auto_rotate && camera.rotation_deg_per_s != 0.0) {
      when = allowed;
    } else if (view.last_reduced) {
      when = std::max(allowed, view.last_change_ns + seconds_to_ns(timing_.settle_s));
    }
    next = std::min(next, when);
  }
  return next;
}

std::vector<DueRender> ViewSet::take_due(std::uint64_t now_ns) {
  std::vector<DueRender> due;
  const std::uint64_t period = frame_period_ns();
  for (auto& [id, view] : views_) {
    const render::RenderConfig config = config_of(view, id, now_ns);
    const bool rotating = config.view.auto_rotate && config.view.rotation_deg_per_s != 0.0;
    const bool allowed = !view.rendered || now_ns >= view.last_render_ns + period;
    const bool wanted =
        view.due ||
        (view.rendered && (rotating || (view.last_reduced && !moving(view, config.view, now_ns))));
    if (!allowed || !wanted) continue;
    DueRender render;
    render.view_id = id;
    render.config = config;
    render.generation = generation_;
    render.reduced =
        timing_.reduce_while_moving && !view.force_full && moving(view, config.view, now_ns);
    if (render.reduced) shrink(render.config.view, timing_.moving_scale);
    view.due = false;
    view.force_full = false;
    view.rendered = true;
    view.last_render_ns = now_ns;
    view.last_reduced = render.reduced;
    due.push_back(std::move(render));
  }
  return due;
}

DueRender ViewSet::take_shared(std::uint64_t now_ns) {
  View& view = views_.at(kSharedView);
  DueRender render;
  render.view_id = kSharedView;
  render.config = config_of(view, kSharedView, now_ns);
  render.generation = generation_;
  render.reduced =
      timing_.reduce_while_moving && !view.force_full && moving(view, render.config.view, now_ns);
  if (render.reduced) shrink(render.config.view, timing_.moving_scale);
  view.due = false;
  view.force_full = false;
  view.rendered = true;
  view.last_render_ns = now_ns;
  view.last_reduced = render.reduced;
  return render;
}

}  // namespace ioct::gpu::live
