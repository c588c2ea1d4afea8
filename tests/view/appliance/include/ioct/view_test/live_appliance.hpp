// The whole appliance on the simulator, as processes a test can start, stop and restart one by
// one: ioct-rt (small raster, control socket), ioct-gpu (frame ring, view socket) and ioct-view
// (HTTP and WebSocket on a free local port, a known operator token). Names are unique to the
// test (ring, frame ring, sockets, folder); logs, state and snapshots live in the test's folder,
// which is kept when the test fails.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "ioct/test_support/scoped_shm_name.hpp"
#include "ioct/view_test/http_client.hpp"
#include "ioct/view_test/logged_process.hpp"

namespace ioct::view_test {

struct ApplianceOptions {
  std::string tag = "view";  // part of the ring's name and of the folder's
  // A small raster at a quarter of the real sweep rate, as the e2e test uses, so a loaded 2-core
  // machine keeps up on the CPU path: 128 A-scans x 8 B-scans per group (49 ms), 32 per volume.
  std::uint32_t samples = 512;  // k-clock samples per A-scan: 256 px of depth
  std::uint32_t ascans = 128;
  std::uint32_t bscans_per_group = 8;
  std::uint32_t bscans_per_volume = 32;
  double ascan_rate_hz = 25'000.0;
  std::uint32_t render_width = 320;
  std::uint32_t render_height = 240;
  double stale_after_s = 1.0;  // ioct-view --stale-after (a loaded CI machine lags at times)
  std::string token = "operator-token-for-the-browser-tests";
  // Instruments in the simulated scene (ioct-rt --sim-instrument); any turns on ioct-gpu's
  // instrument detection (--instruments).
  std::vector<std::string> instruments;
};

class LiveAppliance {
 public:
  // Prepares names, folder and token file; starts nothing.
  explicit LiveAppliance(ApplianceOptions options = {});
  ~LiveAppliance();  // stops every process (view, gpu, rt), removes the folder unless kept

  // Starts ioct-rt, ioct-gpu and ioct-view and waits until ioct-view answers GET /api/params
  // (it has heard from ioct-gpu); throws with the logs when it does not within `timeout`.
  void start_all(std::chrono::milliseconds timeout = std::chrono::milliseconds(20'000));
  void stop_all();

  LoggedProcess& rt() noexcept { return *rt_; }
  LoggedProcess& gpu() noexcept { return *gpu_; }
  LoggedProcess& view() noexcept { return *view_; }
  // Starts ioct-view (again) and waits until it answers; throws with its log when it does not.
  void start_view(std::chrono::milliseconds timeout = std::chrono::milliseconds(20'000));

  // One command to ioct-rt's control socket (start, stop, status), through ioct-rtctl; returns
  // the reply line (JSON), or throws with what ioct-rtctl said.
  std::string rt_command(const std::string& command);

  unsigned short port() const noexcept { return port_; }
  const std::string& token() const noexcept { return options_.token; }
  // http://127.0.0.1:PORT<path>; the operator's URL carries the token in its fragment.
  std::string url(const std::string& path = "/") const;
  std::string operator_url(const std::string& path = "/control") const;
  HttpReply http(const std::string& method, const std::string& target, const std::string& body = "",
                 bool as_operator = false) const;

  const std::filesystem::path& folder() const noexcept { return folder_; }
  void keep_folder() noexcept { keep_ = true; }
  // The end of each process's log, for a failure message.
  std::string logs() const;

 private:
  using Clock = std::chrono::steady_clock;
  // GET `target` until it answers 200; throws `failure` with the last reply and the logs when
  // `deadline` passes or a `needed` process exits first.
  void await_ok(const std::string& target, Clock::time_point deadline,
                std::initializer_list<LoggedProcess*> needed, const std::string& failure);

  ApplianceOptions options_;
  test_support::ScopedShmName ring_;
  std::filesystem::path folder_;
  std::string control_socket_;
  std::string view_socket_;
  unsigned short port_ = 0;
  bool keep_ = false;
  std::unique_ptr<LoggedProcess> rt_;
  std::unique_ptr<LoggedProcess> gpu_;
  std::unique_ptr<LoggedProcess> view_;
};

}  // namespace ioct::view_test
