#include "ioct/gpu/volume_assembler.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace ioct::gpu {

VolumeAssembler::VolumeAssembler(std::uint32_t bscans_per_volume, std::uint32_t depth)
    : bscans_per_volume_(bscans_per_volume), depth_(depth), placed_(bscans_per_volume, false) {
  if (bscans_per_volume == 0 || depth == 0) {
    throw std::invalid_argument("VolumeAssembler: " + std::to_string(bscans_per_volume) +
                                " B-scans of depth " + std::to_string(depth));
  }
}

void VolumeAssembler::begin_volume(std::uint64_t volume_index, std::uint32_t ascans) {
  if (volume_.ascans() != ascans || volume_.bscans() != bscans_per_volume_) {
    volume_.reshape(bscans_per_volume_, ascans, depth_);
  }
  std::fill(placed_.begin(), placed_.end(), false);
  progress_ = VolumeInfo{volume_index, 0, bscans_per_volume_, 0};
}

VolumeInfo VolumeAssembler::finish_volume() {
  for (std::uint32_t b = 0; b < bscans_per_volume_; ++b) {
    if (!placed_[b]) std::ranges::fill(volume_.bscan(b), std::uint8_t{0});
  }
  const VolumeInfo info = *progress_;
  progress_.reset();
  return info;
}

PlacementResult VolumeAssembler::place(const ProcessedGroup& group,
                                       const CompletionHandler& on_complete) {
  if (group.depth != depth_) {
    throw std::invalid_argument("VolumeAssembler: group of depth " + std::to_string(group.depth) +
                                ", the volume's is " + std::to_string(depth_));
  }
  PlacementResult result;
  for (std::uint32_t b = 0; b < group.bscan_count; ++b) {
    const shm::BscanMarker& marker = group.markers[b];
    if (marker.bscan_in_volume >= bscans_per_volume_ || last_completed_ == marker.volume_index) {
      ++result.bscans_rejected;  // out of range, or late for a volume already shown
      continue;
    }
    if (!progress_ || progress_->volume_index != marker.volume_index) {
      if (progress_ && progress_->bscans_placed > 0) ++result.volumes_abandoned;
      begin_volume(marker.volume_index, group.ascans);
    }
    if (group.ascans != volume_.ascans()) {
      ++result.bscans_rejected;  // the scan changed width inside a volume
      continue;
    }
    std::ranges::copy(group.bscan(b), volume_.bscan(marker.bscan_in_volume).begin());
    if (!placed_[marker.bscan_in_volume]) {
      placed_[marker.bscan_in_volume] = true;
      ++progress_->bscans_placed;
      --progress_->bscans_missing;
    }
    progress_->last_group_index = group.group_index;
    ++result.bscans_placed;
    if ((marker.flags & shm::kBscanVolumeEnd) != 0) {
      const VolumeInfo info = finish_volume();
      last_completed_ = info.volume_index;
      ++result.volumes_completed;
      if (on_complete) on_complete(volume_, info);
    }
  }
  return result;
}

bool VolumeAssembler::reset() {
  const bool abandoned = progress_ && progress_->bscans_placed > 0;
  progress_.reset();
  last_completed_.reset();
  return abandoned;
}

std::optional<VolumeInfo> VolumeAssembler::seal_partial() {
  if (!progress_ || progress_->bscans_placed == 0) return std::nullopt;
  return finish_volume();
}

}  // namespace ioct::gpu
