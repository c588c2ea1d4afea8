// Raw spectra from a file or a recording through the same processing chain as the live system: the
// file's B-scans are cut into groups as the ring would carry them, each with the slot header and
// markers the producer would write, processed by the OctProcessor of the chosen backend and
// placed by the VolumeAssembler; the volume filters follow when asked for.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "ioct/gpu/filters/filter_config.hpp"
#include "ioct/gpu/offline/progress_bar.hpp"
#include "ioct/gpu/offline/raw_spectra_file.hpp"
#include "ioct/gpu/offline/spectra_source.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu::offline {

struct RawProcessingSettings {
  Backend backend = Backend::cpu;
  OctProcessorConfig processing;
  std::uint32_t bscans_per_group = 16;  // as the ring would carry them (clamped to the file's)
  bool bidirectional = false;           // odd B-scans were acquired right to left
  std::optional<filters::VolumeFilterConfig> filter;  // median + Gaussian after processing
};

struct RawProcessingResult {
  Volume volume;
  std::string processor_backend;  // "cpu" or "cuda"
  std::string filter_backend;     // empty when not filtered
};

// Throws ConfigError for settings the chain refuses (naming the key), BackendUnavailable,
// InputFileError for read failures, and std::runtime_error when the chain places fewer B-scans
// than the file holds.
RawProcessingResult process_raw_file(const SpectraSource& file,
                                     const RawProcessingSettings& settings,
                                     ProgressBar* progress = nullptr);

}  // namespace ioct::gpu::offline
