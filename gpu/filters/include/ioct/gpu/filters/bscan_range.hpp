// Which B-scans incremental filtering touches. A group of new B-scans [first, first + count)
// changes the median of every B-scan whose 3x3x3 neighbourhood reaches into it, i.e. the output
// B-scans [first - 1, first + count + 1); computing those reads the input B-scans
// [first - 2, first + count + 2). The Gaussian works inside each B-scan and adds no halo. Ranges
// are clipped to the volume: at its first and last B-scan the median repeats the edge B-scan.
#pragma once

#include <cstdint>

namespace ioct::gpu::filters {

struct BscanRange {
  std::uint32_t first = 0;
  std::uint32_t count = 0;
  std::uint32_t end() const noexcept { return first + count; }
  friend bool operator==(const BscanRange&, const BscanRange&) = default;
};

// The output B-scans to recompute when input B-scans `changed` of a volume of `bscans` changed.
// Throws std::out_of_range when `changed` is empty or reaches past the volume.
BscanRange outputs_affected_by(BscanRange changed, std::uint32_t bscans);

// The input B-scans needed to compute output B-scans `outputs`.
BscanRange inputs_needed_for(BscanRange outputs, std::uint32_t bscans);

}  // namespace ioct::gpu::filters
