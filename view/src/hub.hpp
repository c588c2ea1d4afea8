// The meeting point on ioct-view's io thread: the newest frames from the follower, the state of
// the pipeline and of the scan, and every connected viewer. A frame is offered to the viewers of
// its view; each viewer keeps only the newest one it has not sent (its own queue of one), so a slow
// viewer drops frames and never holds up another. Single-threaded: everything runs on the io
// thread, so nothing here takes a lock.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "backends.hpp"
#include "frame_follower.hpp"
#include "frame_message.hpp"
#include "latency_record.hpp"

namespace ioct::view {

// A connected browser as the hub sees it (a WebSocket session).
class Viewer {
 public:
  virtual ~Viewer() = default;
  virtual std::uint64_t watched_view() const = 0;  // 0: the shared view
  virtual bool is_operator() const = 0;
  virtual void offer_frame(const FrameMessage& frame) = 0;
  // The newest state: replaces one not yet sent.
  virtual void offer_state(std::shared_ptr<const std::string> state) = 0;
  // An event every viewer must see (a footswitch action): queued, never replaced.
  virtual void send_event(std::shared_ptr<const std::string> event) = 0;
  // Its own view no longer exists (ioct-gpu restarted or its connection was renewed): back to
  // the shared view, and the page is told why.
  virtual void drop_own_view(const std::string& reason) = 0;
};

struct HubCounters {
  std::uint64_t frames_in = 0;
  std::uint64_t frames_offered = 0;  // frames x viewers
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_replaced = 0;  // dropped for a viewer because a newer one came first
  std::uint64_t viewers_total = 0;
  std::uint64_t messages_refused = 0;
  std::uint64_t connections_refused = 0;
};

class Hub {
 public:
  Hub() = default;

  void join(const std::shared_ptr<Viewer>& viewer);
  void leave(const Viewer* viewer);
  std::size_t viewers() const noexcept { return viewers_.size(); }

  void on_frame(const std::shared_ptr<const shm::Frame>& frame, std::uint64_t now_ns);
  void on_follower(const FollowerSnapshot& snapshot);
  void on_backends(const BackendsSnapshot& snapshot);
  // Called (on the io thread) once for every footswitch press the backends saw.
  void set_footswitch_handler(std::function<void()> handler) {
    on_footswitch_ = std::move(handler);
  }
  // Sends a text message to every viewer (e.g. {"type":"footswitch",...}).
  void broadcast_event(const std::string& text);
  // Sends the state to every viewer (the io thread's 4 Hz timer, and at every signal change).
  void broadcast_state();

  // {"type":"state", ...} as in docs/live-view.md; `role` "viewer" or "operator".
  nlohmann::json state(const std::string& role) const;
  const BackendsSnapshot& backends() const noexcept { return backends_; }
  const FollowerSnapshot& follower() const noexcept { return follower_; }

  std::uint64_t new_view_id() noexcept { return next_view_id_++; }

  // Latencies measured here (ms figures in the metrics): group published → frame sent to a viewer,
  // and → frame drawn by the page (reported back by it).
  LatencyRecord& published_to_sent() noexcept { return published_to_sent_; }
  LatencyRecord& published_to_drawn() noexcept { return published_to_drawn_; }
  HubCounters& counters() noexcept { return counters_; }
  // The instrument of the newest frame of the shared view (state off until one came).
  const shm::FrameInstrument& instrument() const noexcept { return instrument_; }
  // Open connections, HTTP and WebSocket, in all and per remote address (the listener's limits).
  void connection_opened(const std::string& address) { ++connections_from_[address]; }
  void connection_closed(const std::string& address) {
    if (--connections_from_[address] <= 0) connections_from_.erase(address);
  }
  int connections() const noexcept {
    int all = 0;
    for (const auto& [address, count] : connections_from_) all += count;
    return all;
  }
  int connections_from(const std::string& address) const {
    const auto it = connections_from_.find(address);
    return it == connections_from_.end() ? 0 : it->second;
  }

 private:
  std::map<const Viewer*, std::weak_ptr<Viewer>> viewers_;
  FollowerSnapshot follower_;
  BackendsSnapshot backends_;
  Signal last_signal_ = Signal::no_signal;
  std::uint64_t next_view_id_ = 1;
  LatencyRecord published_to_sent_;
  LatencyRecord published_to_drawn_;
  HubCounters counters_;
  shm::FrameInstrument instrument_{};
  // The B-scan and tip pair of the last frame made into a message, and their number (a new one
  // whenever the bytes change): a viewer sent them already is sent a frame without them.
  std::string last_pictures_;
  std::uint64_t pictures_ = 0;
  std::map<std::string, int> connections_from_;
  std::function<void()> on_footswitch_;
};

// One open connection as the hub counts it (in all and by its peer's address). It moves with the
// socket from the HTTP session to the WebSocket session that session becomes: one connection,
// counted once.
class CountedConnection {
 public:
  CountedConnection(Hub& hub, std::string address) : hub_(&hub), address_(std::move(address)) {
    hub_->connection_opened(address_);
  }
  CountedConnection(CountedConnection&& other) noexcept
      : hub_(std::exchange(other.hub_, nullptr)), address_(std::move(other.address_)) {}
  CountedConnection& operator=(CountedConnection&&) = delete;
  CountedConnection(const CountedConnection&) = delete;
  CountedConnection& operator=(const CountedConnection&) = delete;
  ~CountedConnection() {
    if (hub_ != nullptr) hub_->connection_closed(address_);
  }

 private:
  Hub* hub_;
  std::string address_;
};

}  // namespace ioct::view
