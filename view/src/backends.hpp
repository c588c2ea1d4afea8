// ioct-view's clients of the two other processes: ioct-gpu's view socket (render parameters,
// views, snapshots) and ioct-rt's control socket (scan start/stop/pattern, status). The calls run
// on a thread of their own with bounded timeouts, so a peer that hangs never holds up a browser;
// replies are handed back through `deliver` (ioct-view posts them onto its io thread).
//
// The thread also polls: ioct-rt's status, ioct-gpu's parameters, ioct-record's status (metrics),
// and when ioct-gpu comes (back) it re-applies the parameters last saved, so settings survive a
// restart of either side.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>

#include "preset_store.hpp"
#include "view_config.hpp"

namespace ioct {
class LineClient;
}

namespace ioct::view {

// What the poller last learnt, for the state message.
struct BackendsSnapshot {
  nlohmann::json rt_status;  // ioct-rt's status reply's "status", or null
  std::string rt_error;      // why it is not known
  nlohmann::json params;     // ioct-gpu's shared-view parameters, or null
  std::uint64_t generation = 0;
  std::string gpu_error;
  // Why the operators' last parameters (params.json) were not given to ioct-gpu when it came
  // (back): the file cannot be used, or ioct-gpu refused them; empty when they were.
  std::string params_problem;
  std::uint64_t footswitch_presses = 0;  // footswitch presses so far (ioct-rt counts them)
  nlohmann::json record_status;          // ioct-record's record-status "status"; null: no recorder
};

class Backends {
 public:
  using Reply = std::function<void(nlohmann::json)>;
  using Deliver = std::function<void(std::function<void()>)>;  // runs a task on the io thread
  using OnSnapshot = std::function<void(const BackendsSnapshot&)>;

  Backends(const ViewConfig& config, PresetStore& presets, Deliver deliver, OnSnapshot on_snapshot);
  ~Backends();  // shutdown()
  // Stops the thread; later requests are refused (return false). Idempotent.
  void shutdown();
  Backends(const Backends&) = delete;
  Backends& operator=(const Backends&) = delete;

  // One request to ioct-gpu / ioct-rt; `reply` gets the peer's reply object, or
  // {"ok":false,"error":...,"unavailable":true} when the peer cannot be reached. False (and no
  // call) when more than kMaxQueued requests wait: the caller answers "busy".
  bool gpu(nlohmann::json request, Reply reply);
  bool rt(nlohmann::json request, Reply reply);

  static constexpr std::size_t kMaxQueued = 64;

 private:
  struct Job {
    bool to_gpu = true;
    nlohmann::json request;
    Reply reply;
  };
  bool enqueue(Job job);
  void run();
  void poll_rt(LineClient& client, BackendsSnapshot& snap);
  void count_footswitch_presses(BackendsSnapshot& snap);
  void poll_gpu(LineClient& client, BackendsSnapshot& snap);
  // Gives a (re)connected ioct-gpu the operators' last parameters unless it has them; why not,
  // or empty.
  std::string restore_last_params(LineClient& client, const nlohmann::json& current);
  static void poll_record(LineClient& client, BackendsSnapshot& snap);

  const ViewConfig config_;
  PresetStore& presets_;
  Deliver deliver_;
  OnSnapshot on_snapshot_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job> jobs_;
  bool stop_ = false;
  bool gpu_was_connected_ = false;
  bool footswitch_down_ = false;
  std::optional<std::uint64_t> footswitch_count_;  // ioct-rt's press count at the last poll
  std::thread thread_;
};

}  // namespace ioct::view
