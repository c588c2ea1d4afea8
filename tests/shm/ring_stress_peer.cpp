// ring_stress_peer: the other process of the multi-process ring tests. The tests start it with
// posix_spawn and read what it prints (peer_line.hpp).
//
//   ring_stress_peer reader --ring N --groups G [--seed S] [--api copy|ticket]
//                           [--stall-probability P] [--max-stall-us U] [--idle-sleep-us I]
//                           [--timeout-s T]
//       attaches, prints "ready", reads with random stalls until it has caught up with group G,
//       prints "result ..." with its counters and verification, exits 0 when all is well.
//   ring_stress_peer stuck-reader --ring N [--timeout-s T]
//       attaches, takes a read ticket (begin_read), prints "holding", and never calls end_read:
//       it sleeps until killed, as a reader that died in mid-read.
//   ring_stress_peer writer --ring N [--samples A --ascans B --bscans C --slots S]
//                           [--period-us P] [--groups G]
//       creates the ring, prints "ready epoch=E action=...", publishes test groups every P us
//       until G are published (0: no limit) or SIGTERM, then closes it in order ("closed").
#include <signal.h>
#include <sys/prctl.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include "attach_when_ready.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "stalling_reader.hpp"
#include "test_group.hpp"

namespace {

using namespace ioct;
using Clock = std::chrono::steady_clock;

class Options {
 public:
  Options(int argc, char** argv) {
    for (int i = 2; i + 1 < argc; i += 2) {
      const std::string key = argv[i];
      if (key.rfind("--", 0) != 0) throw std::invalid_argument("expected --key, got " + key);
      values_[key.substr(2)] = argv[i + 1];
    }
  }
  std::string text(const std::string& key, const std::string& fallback = "") const {
    const auto it = values_.find(key);
    if (it != values_.end()) return it->second;
    if (fallback.empty()) throw std::invalid_argument("missing --" + key);
    return fallback;
  }
  std::uint64_t number(const std::string& key, std::uint64_t fallback) const {
    const auto it = values_.find(key);
    return it == values_.end() ? fallback : std::stoull(it->second);
  }
  double real(const std::string& key, double fallback) const {
    const auto it = values_.find(key);
    return it == values_.end() ? fallback : std::stod(it->second);
  }

 private:
  std::map<std::string, std::string> values_;
};

void say(const std::string& line) {
  std::fputs((line + "\n").c_str(), stdout);
  std::fflush(stdout);
}

Clock::time_point deadline_of(const Options& options) {
  return Clock::now() + std::chrono::seconds(options.number("timeout-s", 60));
}

shm::ReaderOptions reader_options(const std::string& label) {
  shm::ReaderOptions options;
  options.label = label;
  return options;
}

int run_reader(const Options& options) {
  const std::string name = options.text("ring");
  const std::uint64_t groups = options.number("groups", 0);
  const auto deadline = deadline_of(options);
  shm::RingReader reader =
      ring_test::attach_when_ready(name, reader_options(options.text("label", "peer")), deadline);
  say("ready position=" + std::to_string(reader.position()) +
      " epoch=" + std::to_string(reader.epoch()) + " status=" + *reader.status_object_name());

  ring_test::StallPlan plan;
  plan.seed = options.number("seed", 1);
  plan.stall_probability = options.real("stall-probability", 0.0);
  plan.max_stall = std::chrono::microseconds(options.number("max-stall-us", 0));
  plan.idle_sleep = std::chrono::microseconds(options.number("idle-sleep-us", 0));
  const auto api = options.text("api", "copy") == "ticket" ? ring_test::ReadApi::ticket
                                                           : ring_test::ReadApi::copy;
  const ring_test::StallingReadResult r =
      ring_test::read_stalling(reader, groups, api, plan, deadline);

  std::ostringstream line;
  line << "result start=" << r.start_position << " position=" << r.end_position
       << " epoch=" << r.epoch << " consumed=" << r.counters.consumed
       << " dropped_lapped=" << r.counters.dropped_lapped
       << " dropped_behind=" << r.counters.dropped_behind << " resyncs=" << r.counters.resyncs
       << " epoch_changes=" << r.counters.epoch_changes << " verified=" << r.verifier.verified()
       << " failures=" << r.verifier.failures() << " stalls=" << r.stalls
       << " rejected_damaged=" << r.rejected_copies_damaged << " caught_up=" << r.caught_up
       << " producer_gone=" << r.producer_gone << " | " << r.verifier.first_failure();
  say(line.str());
  return r.caught_up && r.verifier.failures() == 0 ? 0 : 1;
}

int run_stuck_reader(const Options& options) {
  const auto deadline = deadline_of(options);
  shm::RingReader reader = ring_test::attach_when_ready(
      options.text("ring"), reader_options(options.text("label", "stuck")), deadline);
  shm::ReadTicket ticket;
  while (reader.begin_read(ticket) != shm::PollStatus::ready) {
    if (Clock::now() > deadline) {
      say("error | no group to hold before the timeout");
      return 1;
    }
    ::usleep(100);
  }
  say("holding group=" + std::to_string(ticket.group) + " status=" + *reader.status_object_name());
  for (;;) ::pause();  // never end_read(): die here when killed
}

std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free);

extern "C" void on_sigterm(int) {
  g_stop.store(true);
}

const char* to_text(shm::StartupAction action) {
  switch (action) {
    case shm::StartupAction::created:
      return "created";
    case shm::StartupAction::reused_stale:
      return "reused_stale";
    case shm::StartupAction::replaced_stale:
      return "replaced_stale";
  }
  return "unknown";
}

int run_writer(const Options& options) {
  struct sigaction action {};
  action.sa_handler = on_sigterm;
  ::sigaction(SIGTERM, &action, nullptr);

  shm::RingConfig config = ring_test::small_test_config(options.text("ring"));
  config.geometry.samples_per_ascan = static_cast<std::uint32_t>(options.number("samples", 8));
  config.geometry.ascans_per_bscan = static_cast<std::uint32_t>(options.number("ascans", 4));
  config.geometry.bscans_per_group = static_cast<std::uint32_t>(options.number("bscans", 2));
  config.slot_count = options.number("slots", 8);
  std::optional<shm::RingWriter> writer;
  try {
    writer.emplace(shm::RingWriter::create(config));
  } catch (const shm::RingError& e) {
    say("error code=" + std::string(shm::to_string(e.code())) + " | " + e.what());
    return 2;
  }
  say("ready epoch=" + std::to_string(writer->epoch()) +
      " action=" + to_text(writer->startup_action()) + " pid=" + std::to_string(::getpid()));

  const std::uint64_t groups = options.number("groups", 0);
  const std::int64_t period_ns = static_cast<std::int64_t>(options.number("period-us", 200)) * 1000;
  timespec due{};
  ::clock_gettime(CLOCK_MONOTONIC, &due);
  while (!g_stop.load() && (groups == 0 || writer->published() < groups)) {
    due.tv_nsec += period_ns;
    while (due.tv_nsec >= 1'000'000'000) {
      due.tv_nsec -= 1'000'000'000;
      ++due.tv_sec;
    }
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, nullptr);
    ring_test::publish_test_group(*writer);
  }
  const std::uint64_t published = writer->published();
  writer->close();
  say("closed published=" + std::to_string(published));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fputs("usage: ring_stress_peer reader|stuck-reader|writer --ring NAME ...\n", stderr);
    return 64;
  }
  // Die with the test: a test that crashes runs no destructor to kill its peers.
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() == 1) return 70;
  try {
    const std::string mode = argv[1];
    const Options options(argc, argv);
    if (mode == "reader") return run_reader(options);
    if (mode == "stuck-reader") return run_stuck_reader(options);
    if (mode == "writer") return run_writer(options);
    std::fprintf(stderr, "ring_stress_peer: unknown mode '%s'\n", mode.c_str());
    return 64;
  } catch (const std::exception& e) {
    say(std::string("error | ") + e.what());
    return 1;
  }
}
