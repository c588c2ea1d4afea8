#include "ioct/view_test/live_appliance.hpp"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <stdexcept>
#include <thread>

#include "ioct/test_support/child_process.hpp"

namespace ioct::view_test {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

std::filesystem::path make_folder(const std::string& tag) {
  static std::atomic<unsigned> counter{0};
  // Short: Unix socket paths live here and may not exceed 107 bytes.
  const std::filesystem::path folder = std::filesystem::temp_directory_path() /
                                       ("ioct-view-" + tag + "-" + std::to_string(::getpid()) +
                                        "-" + std::to_string(counter.fetch_add(1)));
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder / "state");
  return folder;
}

std::string www_folder() {
  if (const char* chosen = std::getenv("IOCT_VIEW_WWW"); chosen && *chosen) return chosen;
  return IOCT_VIEW_WWW_DIR;
}

}  // namespace

LiveAppliance::LiveAppliance(ApplianceOptions options)
    : options_(std::move(options)),
      ring_(options_.tag),
      folder_(make_folder(options_.tag)),
      control_socket_((folder_ / "rt.sock").string()),
      view_socket_((folder_ / "view.sock").string()),
      port_(free_local_port()) {
  const std::filesystem::path token_file = folder_ / "token";
  {
    std::ofstream out(token_file);
    out << options_.token << "\n";
  }
  ::chmod(token_file.c_str(), 0600);  // ioct-view refuses a token others can read

  // The simulator's safety timings for a machine shared with other builds: the simulated laser
  // watchdog and the stall check would otherwise fault a starved but healthy run. What the page
  // tests need is a scanner that stops only when told to.
  const std::filesystem::path rt_config = folder_ / "rt.toml";
  {
    std::ofstream out(rt_config);
    out << "[safety]\nstall_timeout_ms = 10000\n\n[simulation]\nlaser_watchdog_timeout_ms = "
           "10000\n";
  }

  const std::string frames = ring_.str() + ".frames";
  std::vector<std::string> rt_args{"--config",
                                   rt_config.string(),
                                   "--ring",
                                   ring_.str(),
                                   "--samples",
                                   std::to_string(options_.samples),
                                   "--ascans",
                                   std::to_string(options_.ascans),
                                   "--bscans-per-group",
                                   std::to_string(options_.bscans_per_group),
                                   "--bscans-per-volume",
                                   std::to_string(options_.bscans_per_volume),
                                   "--ascan-rate",
                                   std::to_string(options_.ascan_rate_hz),
                                   "--rt-priority",
                                   "0",  // CI runs unprivileged as often as not
                                   "--seed",
                                   "7",
                                   "--control-socket",
                                   control_socket_,
                                   "--seconds",
                                   "0"};
  for (const std::string& tool : options_.instruments) {
    rt_args.insert(rt_args.end(), {"--sim-instrument", tool});
  }
  rt_ = std::make_unique<LoggedProcess>(test_support::sibling_executable("ioct-rt"),
                                        std::move(rt_args), folder_ / "ioct-rt.log");
  std::vector<std::string> gpu_args{"--ring",
                                    ring_.str(),
                                    "--out",
                                    (folder_ / "gpu").string(),
                                    "--wait",
                                    "20",
                                    "--status-interval",
                                    "1",
                                    "--render-width",
                                    std::to_string(options_.render_width),
                                    "--render-height",
                                    std::to_string(options_.render_height),
                                    "--frames",
                                    frames,
                                    "--view-socket",
                                    view_socket_,
                                    "--snapshot-dir",
                                    (folder_ / "snapshots").string()};
  if (!options_.instruments.empty()) gpu_args.emplace_back("--instruments");
  gpu_ = std::make_unique<LoggedProcess>(test_support::sibling_executable("ioct-gpu"),
                                         std::move(gpu_args), folder_ / "ioct-gpu.log");
  view_ = std::make_unique<LoggedProcess>(
      test_support::sibling_executable("ioct-view"),
      std::vector<std::string>{"--listen", "127.0.0.1:" + std::to_string(port_), "--frames", frames,
                               "--view-socket", view_socket_, "--control-socket", control_socket_,
                               "--www", www_folder(), "--token-file", token_file.string(),
                               "--state-dir", (folder_ / "state").string(), "--stale-after",
                               std::to_string(options_.stale_after_s)},
      folder_ / "ioct-view.log");
}

LiveAppliance::~LiveAppliance() {
  stop_all();
  if (!keep_) {
    std::error_code ignored;
    std::filesystem::remove_all(folder_, ignored);
  }
}

void LiveAppliance::start_all(std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  rt_->start();
  gpu_->start();
  start_view(timeout);
  // ioct-view answers before it has heard from ioct-gpu; the appliance is up once the view
  // knows the render parameters (GET /api/params answers 503 until then).
  await_ok("/api/params", deadline, {gpu_.get(), view_.get()},
           "ioct-view had no render parameters from ioct-gpu");
}

void LiveAppliance::stop_all() {
  view_->stop();
  gpu_->stop();
  rt_->stop();
}

void LiveAppliance::start_view(std::chrono::milliseconds timeout) {
  view_->start();
  await_ok("/api/state", Clock::now() + timeout, {view_.get()}, "ioct-view did not answer");
}

void LiveAppliance::await_ok(const std::string& target, Clock::time_point deadline,
                             std::initializer_list<LoggedProcess*> needed,
                             const std::string& failure) {
  HttpReply reply;
  while (Clock::now() < deadline) {
    reply = http("GET", target);
    if (reply.status == 200) return;
    if (std::ranges::any_of(needed, [](LoggedProcess* p) { return !p->running(); })) break;
    std::this_thread::sleep_for(50ms);
  }
  keep_ = true;
  throw std::runtime_error(
      failure + " (GET " + target + ", last: " +
      (reply.status ? std::to_string(reply.status) + " " + reply.body : reply.problem) + ")\n" +
      logs());
}

std::string LiveAppliance::rt_command(const std::string& command) {
  test_support::ChildProcess ctl = test_support::ChildProcess::spawn(
      test_support::sibling_executable("ioct-rtctl"), {"--socket", control_socket_, command});
  std::string reply;
  while (auto line = ctl.read_line(10s)) reply += *line;
  const auto status = ctl.wait_for(10s);
  if (!status || !WIFEXITED(*status) || WEXITSTATUS(*status) != 0) {
    throw std::runtime_error("ioct-rtctl " + command + " failed: " + reply);
  }
  return reply;
}

std::string LiveAppliance::url(const std::string& path) const {
  return "http://127.0.0.1:" + std::to_string(port_) + path;
}

std::string LiveAppliance::operator_url(const std::string& path) const {
  return url(path) + "#token=" + options_.token;
}

HttpReply LiveAppliance::http(const std::string& method, const std::string& target,
                              const std::string& body, bool as_operator) const {
  return http_request(port_, method, target, body, as_operator ? options_.token : "");
}

std::string LiveAppliance::logs() const {
  std::string text;
  for (const LoggedProcess* p : {rt_.get(), gpu_.get(), view_.get()}) {
    text += "--- " + p->describe() + ", its log ends:\n" + p->log_tail(1500) + "\n";
  }
  return text;
}

}  // namespace ioct::view_test
