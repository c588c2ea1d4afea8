// What runs on the live volume after processing: the filters, the segmentation and the renderers
// live in libraries above this one (gpu/live_stages puts them together), so the live loop sees them
// through this interface. The loop calls on_bscans() after every group it placed; a stage copies
// what it needs and does its work on its own thread, so a slow stage (the CPU reference on two
// cores) folds groups together instead of holding up the ring.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"

namespace ioct::gpu {

// The live volume's dimensions: B-scan positions x active A-scans x depth (all 0 before a volume
// has begun).
struct LiveVolumeShape {
  std::uint32_t bscans = 0, ascans = 0, depth = 0;
  bool fits(const Volume& v) const noexcept {
    return v.bscans() == bscans && v.ascans() == ascans && v.depth() == depth;
  }
};

// The live volume as a stage may read it.
class LiveVolumeSource {
 public:
  virtual ~LiveVolumeSource() = default;
  virtual LiveVolumeShape shape() const = 0;
  // Copies B-scans [first, first + count) of the live volume, as of the last group reported,
  // into the same B-scans of `out`. `out` is first reshaped to shape() when it differs (its other
  // B-scans are then unspecified). Throws std::out_of_range for B-scans outside the volume;
  // nothing is copied before a volume has begun (count must then be 0).
  virtual void copy_bscans(std::uint32_t first, std::uint32_t count, Volume& out) = 0;
  // A live volume on the device: calls `enqueue_reads` at once with its view, during which only
  // reads of it may be enqueued on `stream` (they see it as of the last group reported), and
  // returns true. A host live volume returns false and calls nothing.
  virtual bool read_on_device(
      CUstream_st* /*stream*/,
      const std::function<void(const DeviceVolumeView&)>& /*enqueue_reads*/) {
    return false;
  }
};

// For implementations: reshapes `out` to `shape` and checks that [first, first + count) lies
// inside; throws std::out_of_range naming the range.
void prepare_bscan_copy(const LiveVolumeShape& shape, std::uint32_t first, std::uint32_t count,
                        Volume& out);

// The group that brought a hand-over, and the reader's books as of it, so a stage can stamp what
// it makes from the B-scans (frames for viewers carry their group and its age) and report the
// pipeline's state.
struct GroupStamp {
  std::uint64_t group_index = 0;
  std::uint64_t volume_index = 0;     // of the group's first B-scan
  std::uint64_t t_published_ns = 0;   // CLOCK_MONOTONIC, the slot header's t_publish_ns
  std::uint64_t t_processed_ns = 0;   // placed into the live volume
  std::uint64_t ingest_ns = 0;        // the live loop's time on it: read, process, place
  std::uint64_t groups_consumed = 0;  // read intact so far
  std::uint64_t groups_dropped = 0;   // lapped + behind so far
  std::uint64_t volumes_completed = 0;
};

class LiveStage {
 public:
  virtual ~LiveStage() = default;
  // B-scans [first, first + count) of the live volume are new, brought by the group `stamp`
  // describes. Called on the live loop's thread after each group; returns after copying them.
  virtual void on_bscans(LiveVolumeSource& source, std::uint32_t first, std::uint32_t count,
                         const GroupStamp& stamp) = 0;
  // A few words for the live loop's status line ("stages 12 passes, 3 groups folded").
  virtual std::string status() const = 0;
  // End of the run: finishes what was handed over, writes the stage's files into `out_dir` and
  // returns its part of summary.json. Failures are reported in that part, not thrown.
  virtual nlohmann::json finish(const std::filesystem::path& out_dir) = 0;
};

}  // namespace ioct::gpu
