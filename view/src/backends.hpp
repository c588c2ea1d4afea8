// ioct-view's clients of the two other processes: ioct-gpu's view socket (render parameters,
// views, snapshots) and ioct-rt's control socket (scan start/stop/pattern, status). Each peer's
// calls run on a thread of its own (a lane) with bounded timeouts, so a peer that hangs never
// holds up a browser, and a slow one (a snapshot waits seconds for a full-size render on a CPU)
// never holds up the other: a scan stop and ioct-rt's status go on meanwhile. Replies are handed
// back through `deliver` (ioct-view posts them onto its io thread).
//
// The lanes also poll: ioct-rt's status and ioct-record's status (metrics) on one, ioct-gpu's
// parameters on the other, and when ioct-gpu comes (back) it re-applies the parameters last
// saved, so settings survive a restart of either side.
#pragma once

#include <chrono>
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
  // When rt_status came: a poll waits behind the operators' commands to ioct-rt, so the state
  // says how old the scanner's and the laser's state is.
  std::chrono::steady_clock::time_point rt_status_at{};
  nlohmann::json params;  // ioct-gpu's shared-view parameters, or null
  std::uint64_t generation = 0;
  std::string gpu_error;
  // Why the operators' last parameters (params.json) were not given to ioct-gpu when it came
  // (back): the file cannot be used, or ioct-gpu refused them; empty when they were.
  std::string params_problem;
  // The gpu lane's connections to ioct-gpu so far: views opened on an earlier one are gone.
  std::uint64_t gpu_connection = 0;
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
  // Stops the threads; later requests are refused (return false). Idempotent.
  void shutdown();
  Backends(const Backends&) = delete;
  Backends& operator=(const Backends&) = delete;

  // One request to ioct-gpu / ioct-rt; `reply` gets the peer's reply object, or
  // {"ok":false,"error":...,"unavailable":true} when the peer cannot be reached. False (and no
  // call) when more than kMaxQueued requests wait for that peer: the caller answers "busy".
  bool gpu(nlohmann::json request, Reply reply);
  bool rt(nlohmann::json request, Reply reply);

  static constexpr std::size_t kMaxQueued = 64;

 private:
  struct Job {
    nlohmann::json request;
    Reply reply;
  };
  // One peer's queue of requests, served in order with its polls between them.
  struct Lane {
    std::mutex mutex;
    std::condition_variable wake;
    std::deque<Job> jobs;
    bool stop = false;
    std::thread thread;
  };
  static bool enqueue(Lane& lane, Job job);
  // Serves `lane`: `serve` answers a job, `poll` runs every rt_status_interval_s between jobs.
  void run(Lane& lane, const std::function<nlohmann::json(Job&)>& serve,
           const std::function<void()>& poll);
  void run_gpu();
  void run_rt();
  // Copies what one lane learnt into the shared snapshot and delivers it to the io thread.
  void publish(const std::function<void(BackendsSnapshot&)>& update);
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
  std::mutex snapshot_mutex_;
  BackendsSnapshot snapshot_;                      // both lanes' parts; delivered whole
  bool gpu_was_connected_ = false;                 // the gpu lane's
  bool footswitch_down_ = false;                   // the rt lane's
  std::optional<std::uint64_t> footswitch_count_;  // ioct-rt's press count at the last poll
  Lane gpu_lane_;
  Lane rt_lane_;
};

}  // namespace ioct::view
