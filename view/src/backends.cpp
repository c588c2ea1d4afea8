#include "backends.hpp"

#include <chrono>

#include "ioct/common/line_client.hpp"
#include "ioct/common/log.hpp"

namespace ioct::view {
namespace {

using Clock = std::chrono::steady_clock;

nlohmann::json unavailable(const std::string& who, const std::string& why) {
  return {{"ok", false}, {"error", who + " is not reachable: " + why}, {"unavailable", true}};
}

// What is wrong with the fields every caller reads from a peer's reply (with defaults, which
// throw on another type); empty when nothing is.
std::string reply_problem(const nlohmann::json& reply) {
  if (reply.contains("ok") && !reply["ok"].is_boolean()) return "\"ok\" is not true or false";
  if (reply.contains("error") && !reply["error"].is_string()) return "\"error\" is not a string";
  if (reply.contains("unavailable") && !reply["unavailable"].is_boolean()) {
    return "\"unavailable\" is not true or false";
  }
  return {};
}

// ioct-gpu's answer to get: its parameters (an object) and their generation (a count).
bool has_params(const nlohmann::json& reply) {
  return reply.value("ok", false) && reply.contains("params") && reply["params"].is_object() &&
         reply.contains("generation") && reply["generation"].is_number_unsigned();
}

// One request over `client` within `timeout`; the reply parsed, or the reason it failed as an
// error object.
nlohmann::json call(LineClient& client, const std::string& who, const nlohmann::json& request,
                    std::optional<std::chrono::milliseconds> timeout = std::nullopt) {
  if (client.path().empty()) return unavailable(who, "no socket configured");
  const auto line =
      timeout ? client.request(request.dump(), *timeout) : client.request(request.dump());
  if (!line) return unavailable(who, client.last_error());
  nlohmann::json reply = nlohmann::json::parse(*line, nullptr, false);
  if (reply.is_discarded() || !reply.is_object()) {
    return {{"ok", false}, {"error", who + " sent a reply that is not a JSON object"}};
  }
  if (const std::string problem = reply_problem(reply); !problem.empty()) {
    return {{"ok", false}, {"error", who + " sent a reply whose " + problem}};
  }
  return reply;
}

}  // namespace

Backends::Backends(const ViewConfig& config, PresetStore& presets, Deliver deliver,
                   OnSnapshot on_snapshot)
    : config_(config),
      presets_(presets),
      deliver_(std::move(deliver)),
      on_snapshot_(std::move(on_snapshot)) {
  gpu_lane_.thread = std::thread([this] { run_gpu(); });
  rt_lane_.thread = std::thread([this] { run_rt(); });
}

Backends::~Backends() {
  shutdown();
}

void Backends::shutdown() {
  for (Lane* lane : {&gpu_lane_, &rt_lane_}) {
    {
      std::lock_guard lock(lane->mutex);
      lane->stop = true;
    }
    lane->wake.notify_all();
  }
  for (Lane* lane : {&gpu_lane_, &rt_lane_}) {
    if (lane->thread.joinable()) lane->thread.join();
  }
}

bool Backends::gpu(nlohmann::json request, Reply reply) {
  return enqueue(gpu_lane_, {std::move(request), std::move(reply)});
}

bool Backends::rt(nlohmann::json request, Reply reply) {
  return enqueue(rt_lane_, {std::move(request), std::move(reply)});
}

bool Backends::enqueue(Lane& lane, Job job) {
  {
    std::lock_guard lock(lane.mutex);
    if (lane.stop || lane.jobs.size() >= kMaxQueued) return false;
    lane.jobs.push_back(std::move(job));
  }
  lane.wake.notify_one();
  return true;
}

void Backends::publish(const std::function<void(BackendsSnapshot&)>& update) {
  // Delivered under the lock, so the io thread gets the two lanes' snapshots in the order they
  // were made.
  std::lock_guard lock(snapshot_mutex_);
  update(snapshot_);
  deliver_([cb = on_snapshot_, snap = snapshot_] { cb(snap); });
}

void Backends::poll_rt(LineClient& client, BackendsSnapshot& snap) {
  if (client.path().empty()) {
    snap.rt_status = nullptr;
    snap.rt_error = "no control socket configured";
    return;
  }
  const nlohmann::json reply = call(client, "ioct-rt", {{"cmd", "status"}});
  if (reply.value("ok", false) && reply.contains("status") && !reply["status"].is_object()) {
    snap.rt_status = nullptr;
    snap.rt_error = "ioct-rt sent a status that is not a JSON object";
  } else if (reply.value("ok", false) && reply.contains("status")) {
    snap.rt_status = reply["status"];
    snap.rt_status_at = std::chrono::steady_clock::now();
    snap.rt_error.clear();
    count_footswitch_presses(snap);
  } else {
    snap.rt_status = nullptr;
    snap.rt_error = reply.value("error", std::string("no status"));
  }
}

void Backends::count_footswitch_presses(BackendsSnapshot& snap) {
  const nlohmann::json* safety = nullptr;
  if (snap.rt_status.contains("safety") && snap.rt_status["safety"].is_object()) {
    safety = &snap.rt_status["safety"];
  }
  // ioct-rt counts the presses where it reads the line (every ms): their difference between two
  // polls loses no tap shorter than a poll. A count that went back is a restarted ioct-rt.
  if (safety != nullptr && safety->contains("footswitch_presses") &&
      (*safety)["footswitch_presses"].is_number_unsigned()) {
    const auto count = (*safety)["footswitch_presses"].get<std::uint64_t>();
    if (footswitch_count_ && count >= *footswitch_count_) {
      snap.footswitch_presses += count - *footswitch_count_;
    }
    footswitch_count_ = count;
    return;
  }
  // An ioct-rt without the count: a press is the line seen up, then down, by two polls.
  footswitch_count_.reset();
  const nlohmann::json* inputs =
      safety != nullptr && safety->contains("inputs") ? &(*safety)["inputs"] : nullptr;
  const bool down =
      inputs != nullptr && inputs->is_object() && inputs->value("footswitch", false) == true;
  if (down && !footswitch_down_) ++snap.footswitch_presses;
  footswitch_down_ = down;
}

void Backends::poll_gpu(LineClient& client, BackendsSnapshot& snap) {
  if (client.path().empty()) {
    snap.gpu_error = "no view socket configured";
    return;
  }
  nlohmann::json reply = call(client, "ioct-gpu", {{"cmd", "get"}});
  if (!has_params(reply)) {
    snap.params = nullptr;
    snap.gpu_error = !reply.value("ok", false)
                         ? reply.value("error", std::string("no parameters"))
                         : "ioct-gpu sent parameters without an object \"params\" and a count "
                           "\"generation\"";
    gpu_was_connected_ = false;
    return;
  }
  if (!gpu_was_connected_) {
    // ioct-gpu is (back): give it the parameters the operators last chose.
    gpu_was_connected_ = true;
    snap.params_problem = restore_last_params(client, reply["params"]);
    if (snap.params_problem.empty()) {
      nlohmann::json again = call(client, "ioct-gpu", {{"cmd", "get"}});
      if (has_params(again)) reply = std::move(again);
    } else {
      Log("ioct-view").warning(snap.params_problem);
    }
  }
  snap.params = reply["params"];
  snap.generation = reply["generation"].get<std::uint64_t>();
  snap.gpu_error.clear();
}

std::string Backends::restore_last_params(LineClient& client, const nlohmann::json& current) {
  std::optional<nlohmann::json> last;
  try {
    last = presets_.load_last();
  } catch (const std::exception& e) {
    return std::string("the operators' last parameters were not restored: ") + e.what();
  }
  if (!last || *last == current) return {};
  const nlohmann::json set = call(client, "ioct-gpu", {{"cmd", "set"}, {"changes", *last}});
  if (set.value("ok", false)) return {};
  return "ioct-gpu refused the operators' last parameters (" +
         presets_.last_params_file().string() +
         "): " + set.value("error", std::string("no reason"));
}

void Backends::poll_record(LineClient& client, BackendsSnapshot& snap) {
  snap.record_status = nullptr;  // none configured, not running, or not answering: no metrics
  if (client.path().empty()) return;
  const nlohmann::json reply = call(client, "ioct-record", {{"cmd", "record-status"}});
  if (reply.value("ok", false) && reply.contains("status")) snap.record_status = reply["status"];
}

void Backends::run(Lane& lane, const std::function<nlohmann::json(Job&)>& serve,
                   const std::function<void()>& poll) {
  const auto interval = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(config_.rt_status_interval_s));
  Clock::time_point next_poll = Clock::now();
  std::unique_lock lock(lane.mutex);
  while (!lane.stop) {
    if (lane.jobs.empty()) {
      lane.wake.wait_until(lock, next_poll, [&] { return lane.stop || !lane.jobs.empty(); });
    }
    if (lane.stop) break;
    if (!lane.jobs.empty()) {
      Job job = std::move(lane.jobs.front());
      lane.jobs.pop_front();
      lock.unlock();
      nlohmann::json reply;
      try {
        reply = serve(job);
      } catch (const std::exception& e) {  // this thread must go on serving the others
        reply = {{"ok", false}, {"error", std::string("ioct-view: ") + e.what()}};
      }
      deliver_([cb = std::move(job.reply), r = std::move(reply)]() mutable { cb(std::move(r)); });
      lock.lock();
      continue;
    }
    if (Clock::now() >= next_poll) {
      next_poll = Clock::now() + interval;
      lock.unlock();
      try {
        poll();
      } catch (const std::exception& e) {  // the next poll tries again
        Log("ioct-view").warning(std::string("polling: ") + e.what());
      }
      lock.lock();
    }
  }
}

void Backends::run_gpu() {
  const auto timeout =
      std::chrono::milliseconds(static_cast<std::int64_t>(config_.backend_timeout_s * 1000.0));
  const auto snapshot_timeout =
      std::chrono::milliseconds(static_cast<std::int64_t>(config_.snapshot_timeout_s * 1000.0));
  LineClient client(config_.view_socket.string(), timeout);
  BackendsSnapshot mine;  // this lane's part: params, generation, gpu_error, params_problem
  const auto share = [&] {
    publish([&](BackendsSnapshot& s) {
      s.params = mine.params;
      s.generation = mine.generation;
      s.gpu_error = mine.gpu_error;
      s.params_problem = mine.params_problem;
      s.gpu_connection = client.connections();
    });
  };
  run(
      gpu_lane_,
      [&](Job& job) {
        const std::string cmd = job.request.value("cmd", "");
        nlohmann::json reply = cmd == "snapshot"
                                   ? call(client, "ioct-gpu", job.request, snapshot_timeout)
                                   : call(client, "ioct-gpu", job.request);
        if (reply.value("ok", false) && cmd == "set" && !job.request.contains("view")) {
          // The shared view changed: the state shows it at once, and it is kept for restarts.
          poll_gpu(client, mine);
          if (mine.params.is_object()) {
            try {
              presets_.save_last(mine.params);
            } catch (const std::exception& e) {
              mine.gpu_error = std::string("the parameters could not be kept: ") + e.what();
            }
          }
          share();
        }
        return reply;
      },
      [&] {
        poll_gpu(client, mine);
        share();
      });
  // A job that reconnected is shared by the next poll (at most rt_status_interval_s later).
}

void Backends::run_rt() {
  const auto timeout =
      std::chrono::milliseconds(static_cast<std::int64_t>(config_.backend_timeout_s * 1000.0));
  LineClient rt(config_.control_socket.string(), timeout);
  LineClient record(config_.record_socket.string(), timeout);
  BackendsSnapshot mine;  // this lane's part: rt_status, rt_error, footswitch, record_status
  run(
      rt_lane_, [&](Job& job) { return call(rt, "ioct-rt", job.request); },
      [&] {
        poll_rt(rt, mine);
        poll_record(record, mine);
        publish([&](BackendsSnapshot& s) {
          s.rt_status = mine.rt_status;
          s.rt_status_at = mine.rt_status_at;
          s.rt_error = mine.rt_error;
          s.footswitch_presses = mine.footswitch_presses;
          s.record_status = mine.record_status;
        });
      });
}

}  // namespace ioct::view
