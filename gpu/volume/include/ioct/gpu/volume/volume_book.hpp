// The bookkeeping of placement, apart from the pixels: which positions of the volume in progress
// are filled, when a volume completes or is abandoned, which B-scans are rejected. One book
// drives the host volume (VolumeAssembler) and the device volume of the CUDA pipeline alike, so
// both place, reject, complete and zero by the very same rules:
//
// A volume begins with the first B-scan of a new volume index and is complete when the B-scan
// flagged kBscanVolumeEnd is placed. Positions that never arrived are zeroed at completion, so a
// volume never shows data of an earlier one. A volume whose end never arrives (the group holding
// it was dropped) is abandoned when the next volume begins. A B-scan is rejected when its
// position is out of range, when it belongs to a volume already completed (late), or when its
// width differs from the volume's (the scan changed inside a volume).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "ioct/shm/ring_layout.hpp"

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
  // Positions written, [first_position, end_position): what a later stage has to look at again
  // (empty when nothing was placed). Gaps zeroed at a completion are not included.
  std::uint32_t first_position = 0;
  std::uint32_t end_position = 0;
};

class VolumeBook {
 public:
  // What the book asks of the store that holds the pixels.
  class Pixels {
   public:
    virtual ~Pixels() = default;
    // A new volume of `ascans` A-scans per B-scan begins.
    virtual void begin(std::uint32_t ascans) = 0;
    // B-scan `source` of the group being placed goes to `position`.
    virtual void place(std::uint32_t source, std::uint32_t position) = 0;
    // The volume is finished: zero the positions not `placed`; `info` describes it.
    virtual void finish(const VolumeInfo& info, const std::vector<bool>& placed) = 0;
  };

  explicit VolumeBook(std::uint32_t positions_per_volume);

  // Places the group's B-scans (their markers, in order; all `ascans` wide).
  PlacementResult place(std::span<const shm::BscanMarker> markers, std::uint32_t ascans,
                        std::uint64_t group_index, Pixels& pixels);

  // Forgets the volume in progress (e.g. after a producer restart, whose volume indices start
  // again). Returns true when it held B-scans, i.e. a volume was abandoned.
  bool reset();

  // Finishes the volume in progress as it is (gaps zeroed), for showing a partial volume when
  // the stream ends. Nothing when no B-scan is in progress.
  std::optional<VolumeInfo> seal_partial(Pixels& pixels);

  std::uint32_t positions() const noexcept { return positions_; }

 private:
  VolumeInfo finish(Pixels& pixels);

  std::uint32_t positions_;
  std::uint32_t ascans_ = 0;            // width of the volume in progress
  std::vector<bool> placed_;            // per position of the volume in progress
  std::optional<VolumeInfo> progress_;  // the volume in progress, if any
  std::optional<std::uint64_t> last_completed_;
};

}  // namespace ioct::gpu
