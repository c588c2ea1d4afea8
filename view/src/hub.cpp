#include "hub.hpp"

#include <algorithm>
#include <chrono>
#include <string_view>
#include <vector>

namespace ioct::view {
namespace {

double ms(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-6;
}

std::string_view source_name(std::uint64_t state) {
  switch (static_cast<shm::SourceState>(state)) {
    case shm::SourceState::live:
      return "live";
    case shm::SourceState::producer_gone:
      return "producer_gone";
    case shm::SourceState::waiting:
      return "waiting";
  }
  return "unknown";
}

}  // namespace

void Hub::join(const std::shared_ptr<Viewer>& viewer) {
  viewers_[viewer.get()] = viewer;
  ++counters_.viewers_total;
}

void Hub::leave(const Viewer* viewer) {
  viewers_.erase(viewer);
}

void Hub::on_frame(const std::shared_ptr<const shm::Frame>& frame, std::uint64_t now_ns) {
  ++counters_.frames_in;
  if (frame->meta.view_id == 0) instrument_ = frame->meta.instrument;
  FrameMessage message;  // made once, on first use, for every viewer of the frame's view
  std::vector<std::shared_ptr<Viewer>> to;
  for (auto it = viewers_.begin(); it != viewers_.end();) {
    auto viewer = it->second.lock();
    if (!viewer) {
      it = viewers_.erase(it);
      continue;
    }
    if (viewer->watched_view() == frame->meta.view_id) to.push_back(std::move(viewer));
    ++it;
  }
  if (to.empty()) return;
  const std::size_t render = std::min<std::size_t>(frame->meta.render_bytes, frame->payload.size());
  const std::string_view pictures(reinterpret_cast<const char*>(frame->payload.data()) + render,
                                  frame->payload.size() - render);
  const bool pictures_new = pictures_ == 0 || pictures != last_pictures_;
  if (pictures_new) {
    last_pictures_.assign(pictures);
    ++pictures_;
  }
  message = make_frame_message(*frame, now_ns, pictures_, pictures_new);
  for (const auto& viewer : to) {
    ++counters_.frames_offered;
    viewer->offer_frame(message);
  }
}

void Hub::on_follower(const FollowerSnapshot& snapshot) {
  follower_ = snapshot;
  if (snapshot.verdict.signal != last_signal_) {
    last_signal_ = snapshot.verdict.signal;
    broadcast_state();  // a change of signal is shown at once, not at the next tick
  }
}

void Hub::on_backends(const BackendsSnapshot& snapshot) {
  const bool params_changed =
      snapshot.generation != backends_.generation || snapshot.params != backends_.params;
  const std::uint64_t presses = snapshot.footswitch_presses - backends_.footswitch_presses;
  // ioct-gpu closes a connection's views with it: a viewer orbiting one would otherwise wait for
  // its frames forever, the last picture showing as live.
  const bool views_lost =
      backends_.gpu_connection != 0 && snapshot.gpu_connection != backends_.gpu_connection;
  backends_ = snapshot;
  if (views_lost) {
    for (const auto& [key, weak] : viewers_) {
      if (auto viewer = weak.lock()) {
        viewer->drop_own_view(
            "ioct-gpu's connection was renewed (it restarted, or a request timed out)");
      }
    }
  }
  for (std::uint64_t i = 0; i < presses && on_footswitch_; ++i) on_footswitch_();
  if (params_changed) broadcast_state();
}

nlohmann::json Hub::state(const std::string& role) const {
  const FollowerSnapshot& f = follower_;
  const shm::FrameRingStatus& s = f.status;
  nlohmann::json j;
  j["type"] = "state";
  j["signal"] = std::string(to_string(f.verdict.signal));
  j["reason"] = f.verdict.reason;
  j["age_ms"] = f.verdict.age_ns > 0 ? nlohmann::json(ms(f.verdict.age_ns)) : nullptr;
  j["stale_after_ms"] = ms(f.verdict.bound_ns);
  j["group_period_ms"] = s.group_period_ns > 0 ? nlohmann::json(ms(s.group_period_ns)) : nullptr;
  j["groups_per_s"] = s.group_period_ns > 0 && f.verdict.signal == Signal::live
                          ? 1e9 / static_cast<double>(s.group_period_ns)
                          : 0.0;
  j["dropped"] = s.groups_dropped;
  j["gpu"] = {{"attached", f.attached},
              {"alive", f.health.alive},
              {"source", std::string(source_name(s.source_state))},
              {"groups_consumed", s.groups_consumed},
              {"groups_dropped", s.groups_dropped},
              {"volumes_completed", s.volumes_completed},
              {"last_group", s.last_group_index},
              {"passes", s.passes},
              {"renders", s.renders},
              {"frames_read", f.frames_read},
              {"frames_skipped", f.frames_skipped},
              {"error", f.attached ? std::string() : f.attach_error}};
  j["rt"] = backends_.rt_status;
  j["rt_age_ms"] =
      backends_.rt_status.is_null()
          ? nlohmann::json(nullptr)
          : nlohmann::json(std::chrono::duration<double, std::milli>(
                               std::chrono::steady_clock::now() - backends_.rt_status_at)
                               .count());
  j["rt_error"] = backends_.rt_error;
  j["params"] = backends_.params;
  j["generation"] = backends_.generation;
  j["gpu_error"] = backends_.gpu_error;
  j["params_problem"] = backends_.params_problem;
  j["viewers"] = viewers_.size();
  j["role"] = role;
  return j;
}

void Hub::broadcast_event(const std::string& text) {
  const auto message = std::make_shared<const std::string>(text);
  for (auto it = viewers_.begin(); it != viewers_.end();) {
    auto viewer = it->second.lock();
    if (!viewer) {
      it = viewers_.erase(it);
      continue;
    }
    viewer->send_event(message);
    ++it;
  }
}

void Hub::broadcast_state() {
  if (viewers_.empty()) return;
  const auto as_viewer = std::make_shared<const std::string>(state("viewer").dump());
  const auto as_operator = std::make_shared<const std::string>(state("operator").dump());
  for (auto it = viewers_.begin(); it != viewers_.end();) {
    auto viewer = it->second.lock();
    if (!viewer) {
      it = viewers_.erase(it);
      continue;
    }
    viewer->offer_state(viewer->is_operator() ? as_operator : as_viewer);
    ++it;
  }
}

}  // namespace ioct::view
