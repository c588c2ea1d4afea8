#include "ioct/gpu/volume/volume_book.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace ioct::gpu {

VolumeBook::VolumeBook(std::uint32_t positions_per_volume)
    : positions_(positions_per_volume), placed_(positions_per_volume, false) {
  if (positions_per_volume == 0) {
    throw std::invalid_argument("VolumeBook: a volume of 0 B-scans");
  }
}

VolumeInfo VolumeBook::finish(Pixels& pixels) {
  const VolumeInfo info = *progress_;
  pixels.finish(info, placed_);
  progress_.reset();
  return info;
}

PlacementResult VolumeBook::place(std::span<const shm::BscanMarker> markers, std::uint32_t ascans,
                                  std::uint64_t group_index, Pixels& pixels) {
  PlacementResult result;
  for (std::uint32_t b = 0; b < markers.size(); ++b) {
    const shm::BscanMarker& marker = markers[b];
    if (marker.bscan_in_volume >= positions_ || last_completed_ == marker.volume_index) {
      ++result.bscans_rejected;  // out of range, or late for a volume already shown
      continue;
    }
    if (!progress_ || progress_->volume_index != marker.volume_index) {
      if (progress_ && progress_->bscans_placed > 0) ++result.volumes_abandoned;
      std::fill(placed_.begin(), placed_.end(), false);
      progress_ = VolumeInfo{marker.volume_index, 0, positions_, 0};
      ascans_ = ascans;
      pixels.begin(ascans);
    }
    if (ascans != ascans_) {
      ++result.bscans_rejected;  // the scan changed width inside a volume
      continue;
    }
    pixels.place(b, marker.bscan_in_volume);
    if (result.bscans_placed == 0 || marker.bscan_in_volume < result.first_position) {
      result.first_position = marker.bscan_in_volume;
    }
    result.end_position = std::max(result.end_position, marker.bscan_in_volume + 1);
    if (!placed_[marker.bscan_in_volume]) {
      placed_[marker.bscan_in_volume] = true;
      ++progress_->bscans_placed;
      --progress_->bscans_missing;
    }
    progress_->last_group_index = group_index;
    ++result.bscans_placed;
    if ((marker.flags & shm::kBscanVolumeEnd) != 0) {
      last_completed_ = finish(pixels).volume_index;
      ++result.volumes_completed;
    }
  }
  return result;
}

bool VolumeBook::reset() {
  const bool abandoned = progress_ && progress_->bscans_placed > 0;
  progress_.reset();
  last_completed_.reset();
  return abandoned;
}

std::optional<VolumeInfo> VolumeBook::seal_partial(Pixels& pixels) {
  if (!progress_ || progress_->bscans_placed == 0) return std::nullopt;
  return finish(pixels);
}

}  // namespace ioct::gpu
