// One volume of a raw recording (recording/raw: STEM.json + STEM.raw, written by ioct-sim-record
// or a bench recording) as a source of spectra for offline processing. The recording's metadata
// also says how to process it: its calibration (λ → k resampling), its dispersion and whether
// odd lines run backwards; recording_processing_hints() hands them out.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "ioct/gpu/offline/raw_spectra_file.hpp"
#include "ioct/gpu/offline/spectra_source.hpp"
#include "ioct/recording/recording_reader.hpp"

namespace ioct::gpu::offline {

struct RecordingProcessingHints {
  std::vector<double> resampling_coefficients;  // {0, 1}: already k-linear
  double dispersion_c2 = 0.0;
  double dispersion_c3 = 0.0;
  bool bidirectional = false;
  std::uint32_t bscans_per_group = 16;  // as the recording's groups were cut
};

class RecordingVolume final : public SpectraSource {
 public:
  // Whole volumes the recording holds (its groups x B-scans per group / B-scans per volume).
  static std::uint64_t volume_count(const recording::RecordingReader& reader) noexcept;

  // `path`: the recording's stem or any of its files. `volume`: which volume, 0 first. Throws
  // recording::RecordingError for a damaged recording (naming the file) and InputFileError for a
  // volume it does not hold (saying how many it does).
  RecordingVolume(const std::filesystem::path& path, std::uint64_t volume);

  const RawSpectraLayout& layout() const noexcept override { return layout_; }
  void read_bscans(std::uint32_t first, std::uint32_t count,
                   std::span<std::uint16_t> out) const override;
  std::string describe() const override;

  const recording::RecordingReader& reader() const noexcept { return reader_; }
  std::uint64_t volume() const noexcept { return volume_; }
  // Status bits (recording::kStatus*) of every group the volume was read from so far, or-ed.
  std::uint32_t status_seen() const noexcept { return status_seen_; }
  RecordingProcessingHints processing_hints() const;

 private:
  recording::RecordingReader reader_;
  std::uint64_t volume_ = 0;
  RawSpectraLayout layout_;
  // The last group read, kept so that consecutive B-scans of one group cost one read.
  mutable std::vector<std::uint16_t> group_;
  mutable std::uint64_t group_loaded_ = ~std::uint64_t{0};
  mutable std::uint32_t status_seen_ = 0;
};

}  // namespace ioct::gpu::offline
