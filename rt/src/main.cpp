// ioct-rt: the acquisition process. It creates the shared-memory ring, runs the acquisition
// thread that fills it group by group and the safety thread that owns the laser lines, and on
// this (housekeeping) thread serves the control socket, writes status to the journal (stderr),
// pings systemd's watchdog and stops in order on SIGINT or SIGTERM.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <exception>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "acquisition_loop.hpp"
#include "backends.hpp"
#include "control_protocol.hpp"
#include "effective_config.hpp"
#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/common/input_file.hpp"
#include "ioct/common/log.hpp"
#include "ioct/common/stop_signals.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/scan/scan_builder.hpp"
#include "ioct/scan/scan_infeasible.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/shm/shm_object.hpp"
#include "ioct/sim/replay_digitizer.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "rt_keys.hpp"
#include "rt_options.hpp"
#include "run_summary.hpp"
#include "safety_supervisor.hpp"
#include "sd_notify.hpp"
#include "self_test.hpp"
#include "status_report.hpp"

namespace {

using namespace ioct;

std::string printf_string(const char* format, auto... values) {
  char text[512];
  const int length = std::snprintf(text, sizeof(text), format, values...);
  return std::string(text, static_cast<std::size_t>(std::clamp(length, 0, 511)));
}

double ms(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-6;
}

// Patterns live here, on the housekeeping side, from construction until the acquisition thread
// hands them back.
class PatternStore {
 public:
  const scan::ScanPattern* add(scan::ScanPattern pattern) {
    patterns_.push_back(std::make_unique<scan::ScanPattern>(std::move(pattern)));
    return patterns_.back().get();
  }
  void release(const scan::ScanPattern* pattern) {
    std::erase_if(patterns_, [&](const auto& p) { return p.get() == pattern; });
  }
  std::size_t size() const noexcept { return patterns_.size(); }

 private:
  std::vector<std::unique_ptr<scan::ScanPattern>> patterns_;
};

std::string describe_startup(const shm::RingWriter& ring, const rt::RtSetup& setup,
                             const rt::Backends& backends, const scan::ScanPattern& pattern) {
  const hal::DigitizerConfig& d = setup.digitizer;
  const double group_ms = static_cast<double>(d.sweeps_per_group()) * d.sweep_period_ns() * 1e-6;
  const char* action = ring.startup_action() == shm::StartupAction::created ? "created"
                       : ring.startup_action() == shm::StartupAction::reused_stale
                           ? "reused a dead producer's ring"
                           : "replaced a dead producer's ring";
  return printf_string(
             "ring '%s' %s: %llu slots of %.1f MiB, %s; %s: %u samples x %u A-scans (+%u "
             "flyback) x %u B-scans per group at %.0f Hz = %.2f ms per group (%.2f groups/s), "
             "seed %llu",
             ring.config().name.c_str(), action,
             static_cast<unsigned long long>(ring.layout().slot_count),
             static_cast<double>(ring.layout().group_payload_bytes) / (1024.0 * 1024.0),
             ring.memory_locked() ? "memory locked" : "memory not locked",
             backends.description.c_str(), d.samples_per_ascan, d.ascans_per_bscan,
             d.flyback_sweeps, d.bscans_per_group, d.ascan_rate_hz, group_ms, 1e3 / group_ms,
             static_cast<unsigned long long>(setup.config.simulation_seed)) +
         (setup.config.digitizer_backend == "simulated"
              ? printf_string(", simulation workers %u", setup.simulation.workers)
              : std::string()) +
         "; scan " + pattern.describe() +
         printf_string(" (galvo peak %.3g units/s, %.3g units/s^2)", pattern.usage.peak_velocity,
                       pattern.usage.peak_acceleration);
}

rt::LoopSettings loop_settings(const rt::RtSetup& setup) {
  const rt::RtConfig& c = setup.config;
  rt::LoopSettings s;
  s.geometry = setup.digitizer;
  s.extra_status = !setup.replay_file.empty()           ? shm::kStatusReplay
                   : c.digitizer_backend == "simulated" ? shm::kStatusSimulated
                                                        : 0u;
  s.realtime = setup.realtime;
  s.pace_speed = setup.replay_speed;
  s.stack_prefault_bytes = static_cast<std::size_t>(c.stack_prefault_kib) * 1024;
  s.publish_slack_ns = c.publish_slack_us * 1000;
  s.max_consecutive_misses = c.max_consecutive_deadline_misses;
  s.max_missed_sweeps_per_group = c.max_missed_sweeps_per_group;
  s.check_interval_ns = c.check_interval_us * 1000;
  s.feed_ahead_groups = c.feed_ahead_groups;
  s.park_wait_ns = c.park_wait_ms * 1'000'000;
  s.galvo_lead_samples = c.galvo_lead_samples();
  return s;
}

rt::SupervisorSettings supervisor_settings(const rt::RtSetup& setup) {
  const rt::RtConfig& c = setup.config;
  rt::SupervisorSettings s;
  s.policy.arming_timeout_ns = c.arming_timeout_ms * 1'000'000;
  s.policy.readback_timeout_ns = c.readback_timeout_ms * 1'000'000;
  s.policy.stall_timeout_ns = c.effective_stall_timeout_ms() * 1'000'000;
  s.policy.monitor_laser_ready = c.monitor_laser_ready;
  s.policy.monitor_k_clock = c.monitor_k_clock;
  s.policy.monitor_sweep_trigger = c.monitor_sweep_trigger;
  s.policy.require_footswitch = c.require_footswitch;
  s.policy.auto_rearm_delay_ns = c.auto_rearm_ms * 1'000'000;
  s.poll_interval_ns = c.poll_interval_us * 1000;
  s.watchdog_toggle_interval_ns = c.watchdog_toggle_ms * 1'000'000;
  s.realtime = {c.effective_safety_priority(), c.safety_cpu, false};
  return s;
}

std::string describe_transition(const rt::SafetyTransition& t, const rt::SafetyStatus& status) {
  std::string text =
      "safety: " + std::string(to_string(t.from)) + " -> " + std::string(to_string(t.to));
  if (t.to == rt::SafetyState::fault) text += " (" + rt::describe_faults(t.faults) + ")";
  const rt::SafetyRecord& r = status.record;
  if ((t.to == rt::SafetyState::safe || t.to == rt::SafetyState::idle) &&
      t.from != rt::SafetyState::safe && r.fault_ns != 0 && r.emission_off_ns >= r.fault_ns &&
      r.parked_ns >= r.fault_ns) {
    text += printf_string(": emission off read back %.2f ms and galvos parked %.2f ms after the %s",
                          ms(r.emission_off_ns - r.fault_ns), ms(r.parked_ns - r.fault_ns),
                          t.to == rt::SafetyState::safe ? "fault" : "stop");
  }
  return text;
}

std::string describe_loop_event(const rt::LoopEvent& e) {
  switch (e.kind) {
    case rt::LoopEventKind::armed:
      return printf_string("acquisition: armed (galvo output, then digitizer), scan generation %u",
                           e.value);
    case rt::LoopEventKind::parked:
      return printf_string("acquisition: galvos parked, digitizer stopped at group %llu",
                           static_cast<unsigned long long>(e.group));
    case rt::LoopEventKind::fault:
      return "acquisition: fault posted at group " + std::to_string(e.group) + ": " +
             rt::describe_faults(e.value);
    case rt::LoopEventKind::scan_changed:
      return printf_string("acquisition: scan generation %u scheduled at a volume boundary",
                           e.value);
    case rt::LoopEventKind::simulator_behind:
      return printf_string(
          "acquisition: the simulator is behind: group %llu came %.1f ms after its last sweep "
          "(its synthesis workers, not this loop, are too slow; see simulation.workers)",
          static_cast<unsigned long long>(e.group), static_cast<double>(e.value) * 1e-3);
  }
  return "acquisition: event";
}

int run_self_test(const rt::RtOptions& options) {
  rt::SelfTestSettings settings;
  settings.seconds = options.self_test_seconds;
  settings.interval_ns = options.self_test_interval_us * 1000;
  settings.threshold_ns = options.self_test_threshold_us * 1000;
  // The acquisition thread's real-time request, from the configuration and flags.
  rt::RtSetup setup = rt::make_setup(options);
  settings.realtime = setup.realtime;
  const rt::SelfTestResult result = rt::run_self_test(settings);
  std::fputs(rt::format_self_test(settings, result).c_str(), stdout);
  std::fflush(stdout);
  return result.passed ? 0 : 1;
}

class Process {
 public:
  Process(const rt::RtOptions& options, const StopSignals& signals, const Log& log)
      : options_(options), signals_(signals), log_(log), setup_(rt::make_setup(options)) {}

  int run();

 private:
  // Backends, ring, the acquisition and safety threads.
  void start_threads();
  // The control socket, and scanning when the config says to start with it.
  void open_control();
  // The housekeeping loop: signals, commands, events, watchdog and status lines until a stop;
  // returns why it stopped.
  std::string serve(const rt::StatusSample& first);
  // Emission off and galvos parked, the threads ended, the ring closed, the summary written.
  int shut_down(const std::string& reason, const rt::StatusSample& first);

  std::string handle(const std::string& line);
  nlohmann::json status_now();
  std::string wait_for_request(bool start, std::uint64_t request, const nlohmann::json& id);
  void drain_events();
  bool healthy(std::uint64_t now) const;

  const rt::RtOptions& options_;
  const StopSignals& signals_;
  const Log& log_;
  const rt::SdNotifier notifier_;
  rt::RtSetup setup_;
  PatternStore patterns_;
  rt::Backends backends_;  // before the threads that use it, so it is destroyed after them
  scan::ScanTiming timing_;
  scan::ScanSpec current_spec_;
  std::optional<shm::RingWriter> ring_;
  std::unique_ptr<rt::AcquisitionLoop> loop_;
  std::unique_ptr<rt::SafetySupervisor> supervisor_;
  std::optional<LineServer> control_;
  std::uint64_t started_ns_ = 0;
  std::uint64_t budget_ns_ = 0;
};

nlohmann::json Process::status_now() {
  const rt::StatusSample sample = rt::sample_status(*loop_);
  const std::vector<shm::ReaderReport> readers = ring_->readers();
  nlohmann::json status =
      rt::status_json(sample, started_ns_, budget_ns_, supervisor_->status(), readers);
  status["scan"]["spec"] = {{"pattern", std::string(to_string(current_spec_.kind))},
                            {"repeats", current_spec_.repeats},
                            {"extent_x", current_spec_.extent_x},
                            {"extent_y", current_spec_.extent_y},
                            {"offset_x", current_spec_.offset_x},
                            {"offset_y", current_spec_.offset_y},
                            {"rotation_deg", current_spec_.rotation_deg},
                            {"inactive_ascans", current_spec_.inactive_ascans}};
  status["ring"] = setup_.ring.name;
  // Where the groups come from: a recording replayed, the simulator, or the instrument.
  status["acquisition"]["replay"] = !setup_.replay_file.empty();
  status["acquisition"]["simulated"] =
      setup_.replay_file.empty() && setup_.config.digitizer_backend == "simulated";
  // Why a replay stopped, while it is stopped by it (its digitizer_lost fault says only that
  // the groups ended): the group it could not read, and why.
  if (const auto* replay = dynamic_cast<const sim::ReplayDigitizer*>(backends_.digitizer.get())) {
    status["acquisition"]["replay_error"] = replay->arming_error();
  }
  return status;
}

std::string Process::wait_for_request(bool start, std::uint64_t request, const nlohmann::json& id) {
  // The safety thread takes a request within one poll; wait for it so the reply says what came of
  // it.
  const std::uint64_t give_up = ioct::monotonic_ns() + 500'000'000;
  rt::SafetyStatus s = supervisor_->status();
  while ((start ? s.start_requests_handled : s.stop_requests_handled) < request &&
         ioct::monotonic_ns() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    s = supervisor_->status();
  }
  const char* cmd = start ? "start" : "stop";
  // Two starts in one poll share its answer: the first is refused as the second is.
  if (start && s.last_refusal_first_request <= request && request <= s.last_refusal_request &&
      !s.last_refusal.empty()) {
    return rt::error_reply(std::string(s.last_refusal) + " (state " +
                               std::string(to_string(s.state)) + ", faults " +
                               rt::describe_faults(s.record.faults) + ")",
                           id, cmd);
  }
  nlohmann::json reply = {{"ok", true}, {"cmd", cmd}, {"state", std::string(to_string(s.state))}};
  if (!id.is_null()) reply["id"] = id;
  return reply.dump();
}

std::string Process::handle(const std::string& line) {
  const auto parsed = rt::parse_control_line(line);
  if (const auto* error = std::get_if<rt::ControlParseError>(&parsed)) {
    return rt::error_reply(error->message, error->id);
  }
  const rt::ControlRequest& request = std::get<rt::ControlRequest>(parsed);
  const std::string_view cmd = to_string(request.verb);
  try {
    switch (request.verb) {
      case rt::ControlVerb::status: {
        nlohmann::json reply = {{"ok", true}, {"cmd", "status"}, {"status", status_now()}};
        if (!request.id.is_null()) reply["id"] = request.id;
        return reply.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      }
      case rt::ControlVerb::start:
        return wait_for_request(true, supervisor_->request_start(), request.id);
      case rt::ControlVerb::stop:
        return wait_for_request(false, supervisor_->request_stop(), request.id);
      case rt::ControlVerb::scan: {
        const scan::ScanSpec spec = rt::apply_scan_changes(current_spec_, request.scan_changes);
        scan::ScanPattern built =
            scan::build_scan_pattern(spec, timing_, setup_.config.galvo_limits);
        const std::string description = built.describe();
        const scan::ScanPattern* pattern = patterns_.add(std::move(built));
        if (!loop_->offer_pattern(pattern)) {
          patterns_.release(pattern);
          return rt::error_reply(
              "a scan change is already pending; try again after the next "
              "volume boundary",
              request.id, cmd);
        }
        current_spec_ = spec;
        log_.info("control: scan change accepted: " + description);
        nlohmann::json reply = {{"ok", true},
                                {"cmd", "scan"},
                                {"pattern", description},
                                {"takes_effect", "at the next volume boundary"},
                                {"generation_now", loop_->counters().scan_generation}};
        if (!request.id.is_null()) reply["id"] = request.id;
        return reply.dump();
      }
    }
  } catch (const std::exception& e) {
    return rt::error_reply(e.what(), request.id, cmd);
  }
  return rt::error_reply("unhandled command", request.id, cmd);
}

void Process::drain_events() {
  while (const auto e = loop_->take_event()) log_.info(describe_loop_event(*e));
  if (const std::optional<rt::SafetyTransition> first = supervisor_->take_transition()) {
    const rt::SafetyStatus status = supervisor_->status();
    log_.info(describe_transition(*first, status));
    while (const auto t = supervisor_->take_transition())
      log_.info(describe_transition(*t, status));
  }
  while (const scan::ScanPattern* retired = loop_->take_retired()) patterns_.release(retired);
}

bool Process::healthy(std::uint64_t now) const {
  // The safety thread polls every interval; the acquisition thread beats at least once per group
  // (plus the digitizer's timeout) while it runs, every check interval while parked.
  const std::uint64_t safety_age = now - std::min(now, supervisor_->heartbeat_ns());
  const std::uint64_t loop_age = now - std::min(now, loop_->report().heartbeat_ns);
  return safety_age < 500'000'000 &&
         loop_age < setup_.config.effective_stall_timeout_ms() * 1'000'000;
}

int Process::run() {
  start_threads();
  open_control();
  const rt::StatusSample first = rt::sample_status(*loop_);
  const std::string reason = serve(first);
  return shut_down(reason, first);
}

void Process::start_threads() {
  const rt::RtConfig& config = setup_.config;
  timing_ = scan::ScanTiming::of(config.digitizer, config.bscans_per_volume);
  current_spec_ = config.scan;
  const scan::ScanPattern* initial =
      patterns_.add(scan::build_scan_pattern(current_spec_, timing_, config.galvo_limits));

  // The hardware first: a config it refuses leaves any ring under the name untouched.
  backends_ = rt::make_backends(setup_);
  backends_.digitizer->prepare(setup_.digitizer);
  hal::GalvoOutputConfig galvo = config.galvo;
  galvo.sample_rate_hz = config.digitizer.ascan_rate_hz;
  galvo.lead_samples = 0;  // the acquisition thread shifts the waveform itself (galvo.lead_us)
  backends_.galvo->prepare(galvo);
  backends_.lines->prepare(config.lines);
  ring_.emplace(shm::RingWriter::create(setup_.ring));
  log_.info(describe_startup(*ring_, setup_, backends_, *initial));
  if (const auto* simulator =
          dynamic_cast<const sim::SimulatedDigitizer*>(backends_.digitizer.get());
      simulator != nullptr && setup_.simulation.worker_priority > 0 &&
      simulator->realtime_workers() < simulator->workers()) {
    log_.warning(
        printf_string("simulator: %u of %u synthesis workers could not get SCHED_FIFO %d; they "
                      "run with normal scheduling and may fall behind on a loaded host",
                      simulator->workers() - simulator->realtime_workers(), simulator->workers(),
                      setup_.simulation.worker_priority));
  }

  loop_ = std::make_unique<rt::AcquisitionLoop>(*ring_, *backends_.digitizer, *backends_.galvo,
                                                initial, loop_settings(setup_));
  const rt::RealtimeOutcome loop_outcome = loop_->start();
  supervisor_ =
      std::make_unique<rt::SafetySupervisor>(*backends_.lines, *loop_, supervisor_settings(setup_));
  const rt::RealtimeOutcome safety_outcome = supervisor_->start();
  rt::RealtimeOutcome outcome = loop_outcome;
  outcome.fifo_error = outcome.fifo_error != 0 ? outcome.fifo_error : safety_outcome.fifo_error;
  if (!outcome.complete()) log_.warning(rt::describe_shortfall(setup_.realtime, outcome));
}

void Process::open_control() {
  const rt::RtConfig& config = setup_.config;
  if (!config.control_socket.empty()) {
    control_.emplace(config.control_socket, config.control_group, config.max_clients,
                     config.idle_timeout_ms);
    log_.info("control: listening on " + config.control_socket + " (mode 0660" +
              (config.control_group.empty() ? "" : ", group " + config.control_group) + ")");
  }
  if (config.start_scanning) supervisor_->request_start();
}

std::string Process::serve(const rt::StatusSample& first) {
  budget_ns_ = static_cast<std::uint64_t>(static_cast<double>(setup_.digitizer.sweeps_per_group()) *
                                          setup_.digitizer.sweep_period_ns() / setup_.replay_speed);
  const auto interval_ns = static_cast<std::uint64_t>(setup_.config.status_interval_s * 1e9);
  started_ns_ = first.wall_ns;
  const std::uint64_t end_ns =
      options_.seconds > 0.0 ? started_ns_ + static_cast<std::uint64_t>(options_.seconds * 1e9)
                             : std::numeric_limits<std::uint64_t>::max();
  const std::uint64_t watchdog_ns = notifier_.watchdog_interval_ns().value_or(0) / 2;
  notifier_.notify("READY=1\nSTATUS=acquisition started");
  rt::StatusSample previous = first;
  std::uint64_t next_status_ns = started_ns_ + interval_ns;
  std::uint64_t next_watchdog_ns = started_ns_;
  std::vector<pollfd> fds;
  const LineServer::Handler handler = [this](const std::string& line) { return handle(line); };

  for (;;) {
    std::uint64_t now = ioct::monotonic_ns();
    std::uint64_t wake = std::min({next_status_ns, end_ns, now + 50'000'000});
    if (watchdog_ns != 0) wake = std::min(wake, next_watchdog_ns);
    fds.clear();
    fds.push_back({signals_.fd(), POLLIN, 0});
    if (control_) control_->add_poll_fds(fds);
    const int timeout_ms = wake > now ? static_cast<int>((wake - now + 999'999) / 1'000'000) : 0;
    ::poll(fds.data(), fds.size(), timeout_ms);
    if ((fds[0].revents & POLLIN) != 0) {
      if (const int signal_number = signals_.take(); signal_number != 0) {
        return std::string("stopped by ") + (signal_number == SIGINT ? "SIGINT" : "SIGTERM");
      }
    }
    if (control_) control_->process(fds.data() + 1, fds.size() - 1, handler);
    drain_events();
    now = ioct::monotonic_ns();
    if (watchdog_ns != 0 && now >= next_watchdog_ns) {
      // Fed only while both real-time threads are alive; otherwise systemd restarts us.
      if (healthy(now)) {
        notifier_.notify("WATCHDOG=1\nSTATUS=" +
                         std::string(to_string(supervisor_->status().state)));
      }
      next_watchdog_ns = now + watchdog_ns;
    }
    if (now >= end_ns) return "--seconds elapsed";
    if (now >= next_status_ns) {
      const rt::StatusSample sample = rt::sample_status(*loop_);
      const std::size_t reaped = ring_->reap_dead_readers();
      log_.info(rt::format_status(sample, previous, started_ns_, budget_ns_, supervisor_->status(),
                                  ring_->readers(), reaped));
      previous = sample;
      next_status_ns += interval_ns;
      if (next_status_ns <= sample.wall_ns) next_status_ns = sample.wall_ns + interval_ns;
    }
  }
}

int Process::shut_down(const std::string& reason, const rt::StatusSample& first) {
  notifier_.notify("STOPPING=1\nSTATUS=" + reason);
  // Emission off and galvos parked through the safety machine, then the threads end.
  const std::uint64_t stop_request = supervisor_->request_stop();
  const std::uint64_t give_up = ioct::monotonic_ns() + 2'000'000'000;
  for (;;) {
    const rt::SafetyStatus s = supervisor_->status();
    const bool settled = s.stop_requests_handled >= stop_request &&
                         (s.state == rt::SafetyState::idle || s.state == rt::SafetyState::safe);
    if (settled || ioct::monotonic_ns() > give_up) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  drain_events();
  supervisor_->stop();
  loop_->stop();
  backends_.lines->release();
  drain_events();
  // A replay that stopped on a group it could not read looks like the recording's end to the
  // loop (the digitizer is gone); why, the replay kept (read now: the acquisition thread ended).
  // An earlier arming's failure (a re-arm played the recording again) is reported as that, not
  // as the cause of this stop.
  std::string replay_error;
  std::string replay_earlier_error;
  if (const auto* replay = dynamic_cast<const sim::ReplayDigitizer*>(backends_.digitizer.get())) {
    replay_error = replay->arming_error();
    if (replay->has_error() && replay->error() != replay_error) {
      replay_earlier_error = replay->error();
    }
  }
  if (!replay_error.empty())
    log_.error("the replay stopped at a group it could not read: " + replay_error);
  if (!replay_earlier_error.empty()) {
    log_.warning("an earlier arming of the replay stopped at a group it could not read: " +
                 replay_earlier_error);
  }
  // The readers' counters just before the ring closes, for the summary.
  const std::vector<shm::ReaderReport> readers = ring_->readers();
  ring_->close();
  const rt::StatusSample last = rt::sample_status(*loop_);
  if (!options_.summary.empty()) {
    rt::write_run_summary(options_.summary,
                          {setup_.ring.name, reason, loop_->failure(), replay_error,
                           replay_earlier_error, first, last, budget_ns_, supervisor_->status()},
                          readers);
  }
  const std::string closed =
      rt::format_summary(last, first, budget_ns_) + " | ring '" + setup_.ring.name + "' closed";
  if (loop_->failed()) {
    log_.error("acquisition failed: " + loop_->failure());
    log_.info(closed);
    return ioct::kExitFailed;
  }
  log_.info(reason + " | " + closed);
  return ioct::kExitOk;
}

int check_config(const rt::RtOptions& options) {
  const rt::RtSetup setup = rt::make_setup(options);
  const rt::RtConfig& c = setup.config;
  const auto timing = scan::ScanTiming::of(c.digitizer, c.bscans_per_volume);
  const scan::ScanPattern pattern = scan::build_scan_pattern(c.scan, timing, c.galvo_limits);
  std::printf(
      "configuration ok: ring '%s', %u samples x %u A-scans (+%u flyback) x %u per group "
      "at %.0f Hz, %u B-scans per volume; scan %s; galvo peak %.4g of %.4g units/s, "
      "%.4g of %.4g units/s^2, position %.4g\n",
      c.ring_name.c_str(), c.digitizer.samples_per_ascan, c.digitizer.ascans_per_bscan,
      c.digitizer.flyback_sweeps, c.digitizer.bscans_per_group, c.digitizer.ascan_rate_hz,
      c.bscans_per_volume, pattern.describe().c_str(), pattern.usage.peak_velocity,
      c.galvo_limits.max_velocity, pattern.usage.peak_acceleration, c.galvo_limits.max_acceleration,
      pattern.usage.peak_position);
  // The ring must fit where it will live: a ring larger than the free space is refused here,
  // not found out by a SIGBUS (ShmObject::create allocates it at start).
  const shm::RingLayout layout = shm::RingLayout::compute(
      setup.ring.geometry, setup.ring.slot_count, setup.ring.slot_payload_capacity);
  const std::optional<std::uint64_t> room = shm::room_for_object(setup.ring.name);
  if (room && layout.total_bytes > *room) {
    throw ConfigError("ring.slots", std::to_string(c.ring_slots),
                      "the ring needs " + std::to_string(layout.total_bytes) + " bytes, " +
                          shm::object_path(setup.ring.name) + " has room for " +
                          std::to_string(*room));
  }
  std::printf("ring: %llu bytes, %s bytes free where it lives\n%s",
              static_cast<unsigned long long>(layout.total_bytes),
              room ? std::to_string(*room).c_str() : "unknown",
              rt::effective_config_toml(c).c_str());
  return 0;
}

int run(const rt::RtOptions& options) {
  const StopSignals signals;  // before any thread, so every thread inherits the mask
  const Log log("ioct-rt");
  // A closed stderr must not kill the process before it has closed the ring.
  std::signal(SIGPIPE, SIG_IGN);
  if (options.config_keys) {
    std::fputs(rt::rt_keys().markdown().c_str(), stdout);
    return 0;
  }
  if (options.check_config) return check_config(options);
  if (options.self_test) return run_self_test(options);
  Process process(options, signals, log);
  return process.run();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ioct-rt: acquisition process of the live OCT system. Fills the shared-memory ring with "
      "groups of raw B-scans, drives the galvos and guards the laser; see docs/operations.md."};
  rt::RtOptions options;
  rt::add_rt_options(app, options);
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;

  return ioct::run_command(
      "ioct-rt", [&]() -> int { return run(options); },
      [](const std::string& key) { return rt::option_for_key(key); });
}
