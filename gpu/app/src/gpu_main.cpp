// ioct-gpu: reads raw B-scan groups from the ring, processes them into the live volume, filters,
// segments and renders it group by group, publishes frames for ioct-view and writes the latest
// centre B-scan, en face projection, surfaces and renders as files. Configured by a TOML file and
// flags, each key declared once (gpu_config.cpp).
#include <CLI/CLI.hpp>

#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "gpu_config.hpp"
#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/common/input_file.hpp"
#include "ioct/common/log.hpp"
#include "ioct/common/stop_signals.hpp"
#include "ioct/gpu/ingest/live_processor.hpp"
#include "ioct/gpu/live_stages/processing_view_control.hpp"
#include "ioct/gpu/live_stages/view_socket.hpp"
#include "ioct/gpu/live_stages/volume_stages.hpp"
#include "ioct/shm/ring_error.hpp"

int main(int argc, char** argv) {
  using namespace ioct::gpu;
  std::string config_file;
  ioct::config::Overrides overrides;
  RunLimits limits;
  bool check_config = false;
  bool config_keys = false;

  CLI::App app{
      "ioct-gpu: OCT processing of the ring's raw spectra into the live volume, its "
      "filters, segmentation and renders, frames for ioct-view and PNG previews"};
  app.add_option("--config", config_file,
                 "TOML configuration file (docs/config-keys.md); flags given override its keys")
      ->check(CLI::ExistingFile);
  gpu_keys().add_flags_to(app, overrides);
  app.add_option("--seconds", limits.run_s,
                 "seconds to run; 0: until SIGINT/SIGTERM (or the producer goes, with "
                 "--exit-when-producer-gone)")
      ->capture_default_str();
  app.add_flag("--exit-when-producer-gone", limits.exit_when_producer_gone,
               "finish when the producer closes the ring, instead of waiting for it to come back "
               "and reattaching (a service waits; a demo or a test finishes)");
  app.add_flag("--check-config", check_config,
               "validate the configuration, print it (every key, as TOML) and exit");
  app.add_flag("--config-keys", config_keys,
               "print every configuration key as the Markdown table of docs/config-keys.md, exit");
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;

  return ioct::run_command(
      "ioct-gpu",
      [&]() -> int {
        const ioct::StopSignals signals;  // before any thread, so every thread inherits the mask
        const ioct::Log log("ioct-gpu");
        ioct::StopTarget<LiveProcessor> target;
        const ioct::StopWatcher watcher(signals, [&target](int signal) { target.stop(signal); });
        if (config_keys) {
          std::cout << gpu_keys().markdown();
          return EXIT_SUCCESS;
        }
        GpuSetup setup = make_gpu_setup(config_file, overrides, limits);
        if (check_config) {
          std::cout << "# effective configuration (file, then flags, then defaults)\n"
                    << gpu_keys().to_toml(setup.config);
          return EXIT_SUCCESS;
        }
        const LiveConfig& config = setup.live;
        LiveProcessor processor(config);
        if (config.backend == Backend::cuda) {
          (void)make_oct_processor(config.backend, config.processing);  // fail before waiting
        }
        // "auto" is resolved once the ring is attached (LiveProcessor), with one warning when it
        // falls back to the CPU.
        std::unique_ptr<live::VolumeStages> volume_stages;
        if (setup.stages) {
          volume_stages = std::make_unique<live::VolumeStages>(*setup.stages);
          processor.set_stage(volume_stages.get());
        }
        std::unique_ptr<live::ProcessingViewControl> controls;
        std::unique_ptr<live::ViewSocket> socket;
        if (setup.socket) {
          // The views' parameters and the processing's dB range, as the viewers change them.
          controls = std::make_unique<live::ProcessingViewControl>(
              *volume_stages, [&processor] { return processor.db_range(); },
              [&processor](const DbScaleConfig& scale) { processor.set_db_range(scale); });
          socket = std::make_unique<live::ViewSocket>(*setup.socket, *controls);
        }
        processor.set_log(&log);
        RunSummary summary;
        {
          const auto running = target.running(processor);
          summary = processor.run();
        }
        socket.reset();

        log.info("stopped (" + std::string(to_string(summary.stop_reason)) + ") after " +
                 std::to_string(summary.counters.groups_processed) + " groups, " +
                 std::to_string(summary.counters.volumes_completed) + " volumes");
        if (summary.images) {
          std::cout << "bscan:   " << summary.images->bscan_png.string() << "\n"
                    << "enface:  " << summary.images->enface_png.string() << "\n";
        } else {
          std::cout << "no images: no B-scan was processed\n";
        }
        std::cout << "summary: " << summary.summary_json.string() << std::endl;
        return EXIT_SUCCESS;
      },
      [](const std::string& key) { return gpu_keys().flag_for(key); });
}
