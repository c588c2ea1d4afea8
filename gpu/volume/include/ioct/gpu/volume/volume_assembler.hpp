// Placement into a host volume: processed B-scans go into the volume at the position their
// marker names, never by counting, so a dropped group leaves a gap instead of shifting every
// later B-scan. The rules (completion, zeroed gaps, abandonment, rejection) are VolumeBook's.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "ioct/gpu/volume/processed_group.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_book.hpp"

namespace ioct::gpu {

class VolumeAssembler {
 public:
  using CompletionHandler = std::function<void(const Volume&, const VolumeInfo&)>;

  // positions_per_volume (the ring's bscans_per_volume / repeats) and depth come from the
  // geometry; the width (active A-scans) from the first B-scan of each volume.
  VolumeAssembler(std::uint32_t positions_per_volume, std::uint32_t depth);

  // Places the group's B-scans in order. For every B-scan flagged volume end it calls
  // on_complete with the finished volume before placing anything after it.
  PlacementResult place(const ProcessedGroup& group, const CompletionHandler& on_complete);

  // Forgets the volume in progress (e.g. after a producer restart, whose volume indices start
  // again). Returns true when it held B-scans, i.e. a volume was abandoned.
  bool reset() { return book_.reset(); }

  // Zeroes the B-scans not yet placed in the volume in progress and describes it, for showing a
  // partial volume when the stream ends. Nothing when no B-scan is in progress.
  std::optional<VolumeInfo> seal_partial();

  const Volume& volume() const noexcept { return volume_; }

 private:
  class HostPixels;

  std::uint32_t depth_;
  VolumeBook book_;
  Volume volume_;
};

}  // namespace ioct::gpu
