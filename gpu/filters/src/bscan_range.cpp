#include "ioct/gpu/filters/bscan_range.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace ioct::gpu::filters {
namespace {

BscanRange widened(BscanRange range, std::uint32_t halo, std::uint32_t bscans) {
  const std::uint32_t first = range.first > halo ? range.first - halo : 0;
  const std::uint32_t end = std::min(range.end() + halo, bscans);
  return {first, end - first};
}

}  // namespace

BscanRange outputs_affected_by(BscanRange changed, std::uint32_t bscans) {
  if (changed.count == 0 || changed.first >= bscans || changed.count > bscans - changed.first) {
    throw std::out_of_range("B-scans [" + std::to_string(changed.first) + ", " +
                            std::to_string(std::uint64_t{changed.first} + changed.count) +
                            ") are not a non-empty range of a volume of " + std::to_string(bscans) +
                            " B-scans");
  }
  return widened(changed, 1, bscans);
}

BscanRange inputs_needed_for(BscanRange outputs, std::uint32_t bscans) {
  return widened(outputs, 1, bscans);
}

}  // namespace ioct::gpu::filters
