// Placement: processed B-scans go into the volume at the position their marker names, never by
// counting, so a dropped group leaves a gap instead of shifting every later B-scan.
//
// A volume begins with the first B-scan of a new volume index and is complete when the B-scan
// flagged kBscanVolumeEnd is placed. B-scans that never arrived are zeroed at completion, so a
// volume never shows data of an earlier one. A volume whose end never arrives (the group holding
// it was dropped) is abandoned when the next volume begins.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "ioct/gpu/processed_group.hpp"
#include "ioct/gpu/volume.hpp"

namespace ioct::gpu {

struct VolumeInfo {
  std::uint64_t volume_index = 0;
  std::uint32_t bscans_placed = 0;
  std::uint32_t bscans_missing = 0;  // zeroed: lost to drops or before the reader attached
  std::uint64_t last_group_index = 0;
  bool complete() const noexcept { return bscans_missing == 0; }
};

struct PlacementResult {
  std::uint32_t bscans_placed = 0;
  std::uint32_t bscans_rejected = 0;  // a width that does not match the volume's, or a repeat
  std::uint32_t volumes_completed = 0;
  std::uint32_t volumes_abandoned = 0;
};

class VolumeAssembler {
 public:
  using CompletionHandler = std::function<void(const Volume&, const VolumeInfo&)>;

  // bscans_per_volume and depth come from the ring geometry; the width (active A-scans) from the
  // first B-scan of each volume.
  VolumeAssembler(std::uint32_t bscans_per_volume, std::uint32_t depth);

  // Places the group's B-scans in order. For every B-scan flagged volume end it calls
  // on_complete with the finished volume before placing anything after it.
  PlacementResult place(const ProcessedGroup& group, const CompletionHandler& on_complete);

  // Forgets the volume in progress (e.g. after a producer restart, whose volume indices start
  // again). Returns true when it held B-scans, i.e. a volume was abandoned.
  bool reset();

  // Zeroes the B-scans not yet placed in the volume in progress and describes it, for showing a
  // partial volume when the stream ends. Nothing when no B-scan is in progress.
  std::optional<VolumeInfo> seal_partial();

  const Volume& volume() const noexcept { return volume_; }

 private:
  void begin_volume(std::uint64_t volume_index, std::uint32_t ascans);
  VolumeInfo finish_volume();

  std::uint32_t bscans_per_volume_;
  std::uint32_t depth_;
  Volume volume_;
  std::vector<bool> placed_;            // per B-scan of the volume in progress
  std::optional<VolumeInfo> progress_;  // the volume in progress, if any
  std::optional<std::uint64_t> last_completed_;
};

}  // namespace ioct::gpu
