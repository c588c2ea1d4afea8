// One volume of an HDF5 ring recording (recording/: what ioct-record wrote from the live ring) as
// a source of spectra for offline processing. Volumes are found by the slot headers' markers
// (each B-scan's volume and place in it), not by counting groups: a recording may start in the
// middle of a volume and lose groups, so volume N is the N-th volume (0 first) whose B-scans are
// all in the file. The ring recording carries no calibration: the options give it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "ioct/gpu/offline/raw_spectra_file.hpp"
#include "ioct/gpu/offline/spectra_source.hpp"
#include "ioct/ringrec/ring_recording_reader.hpp"

namespace ioct::gpu::offline {

// True when `path` is an HDF5 file (by its signature), i.e. a ring recording to ioct-process.
bool is_hdf5_file(const std::filesystem::path& path);

class RingRecordingVolume final : public SpectraSource {
 public:
  // Throws ringrec::RingRecordingError for a damaged recording (naming file, group, offset) and
  // InputFileError for a volume it does not hold (saying how many complete ones it does).
  RingRecordingVolume(const std::filesystem::path& path, std::uint64_t volume);

  const RawSpectraLayout& layout() const noexcept override { return layout_; }
  void read_bscans(std::uint32_t first, std::uint32_t count,
                   std::span<std::uint16_t> out) const override;
  std::string describe() const override;

  std::uint64_t complete_volumes() const noexcept { return complete_volumes_; }
  // Some B-scan of the volume was acquired right to left (kBscanReversed).
  bool reversed_lines() const noexcept { return reversed_lines_; }
  std::uint32_t bscans_per_group() const noexcept { return reader_.geometry().bscans_per_group; }
  // The ring's status flags (shm::kStatus*) of the volume's groups, or-ed.
  std::uint32_t status_seen() const noexcept { return status_seen_; }

 private:
  struct Place {
    std::uint64_t group = 0;
    std::uint32_t bscan_in_group = 0;
  };

  ringrec::RingRecordingReader reader_;
  std::uint64_t volume_ = 0;
  std::uint64_t complete_volumes_ = 0;
  RawSpectraLayout layout_;
  std::vector<Place> places_;  // per B-scan of the volume
  bool reversed_lines_ = false;
  std::uint32_t status_seen_ = 0;
  mutable std::vector<std::byte> group_;
  mutable std::uint64_t group_loaded_ = ~std::uint64_t{0};
};

}  // namespace ioct::gpu::offline
