// ioct-record: records the ring's raw groups, their slot headers and the run's description into
// an HDF5 file (SWMR), next to ioct-gpu and without disturbing it or ioct-rt.
#include <CLI/CLI.hpp>

#include <atomic>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>

#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/common/line_server.hpp"
#include "ioct/common/log.hpp"
#include "ioct/common/stop_signals.hpp"
#include "ioct/ringrec/h5_handle.hpp"
#include "ioct/ringrec/recorder_control.hpp"
#include "ioct/ringrec/ring_recorder.hpp"
#include "ioct/shm/ring_error.hpp"

namespace {

constexpr std::size_t kMaxMetadataFileBytes = 1 << 20;
// A directory of its own beside ioct-rt's /run/ioct (which only ioct-rt may write), as ioct-gpu
// has /run/ioct-gpu.
constexpr const char* kDefaultControlSocket = "/run/ioct-record/record.sock";

std::string read_metadata_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("--metadata " + path + ": cannot open");
  std::string text(kMaxMetadataFileBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(in.gcount()));
  if (text.size() > kMaxMetadataFileBytes) {
    throw std::runtime_error("--metadata " + path + ": more than " +
                             std::to_string(kMaxMetadataFileBytes) + " bytes");
  }
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ioct::ringrec;
  RecorderConfig config;
  config.producer = std::string("ioct-record ") + IOCT_VERSION;
  std::string out;
  std::string metadata_file;
  double max_mb = 0.0;
  std::string control_socket;
  std::string control_group;

  CLI::App app{"ioct-record: records the ring's raw groups into an HDF5 file (SWMR)"};
  app.option_defaults()->always_capture_default();
  app.add_option("--ring", config.ring_name, "shared-memory ring to read");
  app.add_option("--out", out,
                 "the HDF5 file to write; with --standby the directory the recordings go into")
      ->required();
  app.add_flag("--standby", config.standby,
               "attach and wait: record only on record-start (control socket), each recording "
               "into a new file of the --out directory");
  app.add_option("--control-socket", control_socket,
                 std::string("the recorder's control socket (record-start, record-stop, "
                             "record-status); default with --standby: ") +
                     kDefaultControlSocket + ", else none");
  app.add_option("--control-group", control_group,
                 "group of the control socket (mode 0660); default: ours");
  app.add_flag("--overwrite", config.overwrite, "replace an existing file");
  app.add_option("--seconds", config.run_s, "seconds to record; 0: until SIGINT/SIGTERM");
  app.add_option("--wait", config.wait_s, "seconds to wait for the ring to appear");
  app.add_flag("--exit-when-producer-gone", config.exit_when_producer_gone,
               "finish when the producer closes the ring instead of waiting for its return");
  app.add_option("--queue-groups", config.queue_groups,
                 "groups that may wait for the disk before groups are dropped (1 to 4096)");
  app.add_option("--max-mb", max_mb,
                 "stop writing past this many MB (drops are counted); 0: no cap");
  app.add_option("--metadata", metadata_file,
                 "a text file stored with the recording (e.g. ioct-rt --check-config's output)");
  app.add_option("--status-interval", config.status_interval_s,
                 "seconds between status lines; 0: none");
  app.add_option("--label", config.label, "the name this reader shows to ioct-rt");
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;

  return ioct::run_command("ioct-record", [&]() -> int {
    const ioct::StopSignals signals;  // before any thread, so every thread inherits the mask
    ioct::StopTarget<RingRecorder> target;
    const ioct::StopWatcher watcher(signals, [&target](int signal) { target.stop(signal); });
    // The status lines are the recorder's output (scripts and tests read them), so standard output.
    const ioct::Log log("ioct-record", std::cout);
    config.out = out;
    if (max_mb < 0 || max_mb > 1e12) {
      throw ioct::ConfigError("max-mb", ioct::format_value(max_mb), "must be in [0, 1e12]");
    }
    config.max_bytes = static_cast<std::uint64_t>(max_mb * 1e6);
    if (!metadata_file.empty()) config.run_metadata = read_metadata_file(metadata_file);
    if (control_socket.empty() && config.standby) control_socket = kDefaultControlSocket;
    RingRecorder recorder(config);
    std::optional<ioct::LineServer> control;
    if (!control_socket.empty()) {
      control.emplace(control_socket, control_group, 8, 30'000,
                      ioct::LineServerNames{"recorder control socket", "ioct-record",
                                            "--control-group", "max clients"});
      log.info("control: listening on " + control_socket);
    }
    std::atomic<bool> control_done{false};
    std::thread control_thread;
    if (control) {
      control_thread = std::thread(
          [&] { ioct::ringrec::serve_recorder_control(*control, recorder, control_done); });
    }
    RecorderSummary summary;
    try {
      const auto running = target.running(recorder);
      summary = recorder.run(&log);
    } catch (...) {
      control_done = true;
      if (control_thread.joinable()) control_thread.join();
      throw;
    }
    control_done = true;
    if (control_thread.joinable()) control_thread.join();
    const CounterValues& c = summary.counters;
    auto at = [&](Counter k) { return c[static_cast<std::size_t>(k)]; };
    std::ostringstream line;
    line << summary.stop_reason << " after " << summary.seconds
         << " s: " << at(Counter::groups_written) << " groups (" << at(Counter::bytes_written)
         << " bytes, writing at " << summary.write_mb_per_s << " MB/s) in "
         << (summary.file.empty() ? std::string("no recording") : summary.file.string())
         << "; lost: lapped " << at(Counter::dropped_lapped) << ", behind "
         << at(Counter::dropped_behind) << ", queue full " << at(Counter::dropped_queue_full)
         << ", disk full " << at(Counter::dropped_disk_full);
    log.info(line.str());
    if (summary.failed) {
      ioct::Log("ioct-record").error(summary.stop_reason);
      return 3;
    }
    return 0;
  });
}
