// Everything ioct-gpu is configured with: read from a TOML file of the same shape as ioct-rt's
// (--config), then overridden by flags. Each key is declared once (gpu_keys(), gpu_config.cpp):
// the file, the range checks, the command line, --check-config's printout and
// docs/config-keys.md read from there.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ioct/config/key_table.hpp"
#include "ioct/gpu/ingest/live_processor.hpp"
#include "ioct/gpu/live_stages/view_socket.hpp"
#include "ioct/gpu/live_stages/volume_stages.hpp"

namespace ioct::gpu {

struct GpuConfig {
  LiveConfig live;  // [ring], [output], [status], [processing]
  // [processing] keys kept as text until the setup resolves them.
  std::string backend = "auto";
  std::string resample = "auto";  // auto: cubic with a calibration, none without
  std::string resample_poly;      // "c0,c1,...": the calibration; empty: none
  // [stages], [render], [sampling], [instruments]
  bool stages_enabled = true;
  std::string filter = "auto";  // auto: median-gauss, the renderer's by render mode
  // Modes rendered once more when the run ends (render-<mode>.png), by render::to_string's names.
  std::vector<std::string> final_modes{"enhanced", "layer-aware", "la-mip"};
  live::VolumeStagesConfig stages;
  // [view]
  std::string frames = "<ring>.frames";
  std::string view_group;
  std::string view_socket;
  std::string snapshot_dir = "<out>/snapshots";
};

const config::KeyTable<GpuConfig>& gpu_keys();

// What ioct-gpu runs with, resolved and validated.
struct GpuSetup {
  GpuConfig config;
  LiveConfig live;
  std::optional<live::VolumeStagesConfig> stages;  // none: --no-stages
  std::optional<live::ViewSocketConfig> socket;    // none: no view socket
};

// How long this run lasts: the command line's alone (--seconds, --exit-when-producer-gone), not
// settings a file keeps.
struct RunLimits {
  double run_s = 0.0;
  bool exit_when_producer_gone = false;
};

// Reads `file` (if not empty), applies the flags given and the run's limits, checks every key and
// each component's validate(), once. Throws config::ConfigFileError ("file:line:col: key = value:
// allowed") for what the file got wrong, ioct::ConfigError naming the key otherwise.
GpuSetup make_gpu_setup(const std::string& file, const config::Overrides& overrides,
                        const RunLimits& limits);

}  // namespace ioct::gpu
