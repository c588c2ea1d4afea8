#include "ioct/gpu/volume/volume_assembler.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace ioct::gpu {

// The pixels of one place() call: copies from the group, zeroes and reports at completion.
class VolumeAssembler::HostPixels final : public VolumeBook::Pixels {
 public:
  HostPixels(VolumeAssembler& owner, const ProcessedGroup* group,
             const CompletionHandler* on_complete)
      : owner_(owner), group_(group), on_complete_(on_complete) {}

  void begin(std::uint32_t ascans) override {
    Volume& v = owner_.volume_;
    if (v.ascans() != ascans || v.bscans() != owner_.book_.positions()) {
      v.reshape(owner_.book_.positions(), ascans, owner_.depth_);
    }
  }
  void place(std::uint32_t source, std::uint32_t position) override {
    std::ranges::copy(group_->bscan(source), owner_.volume_.bscan(position).begin());
  }
  void finish(const VolumeInfo& info, const std::vector<bool>& placed) override {
    for (std::uint32_t p = 0; p < placed.size(); ++p) {
      if (!placed[p]) std::ranges::fill(owner_.volume_.bscan(p), std::uint8_t{0});
    }
    if (on_complete_ != nullptr && *on_complete_) (*on_complete_)(owner_.volume_, info);
  }

 private:
  VolumeAssembler& owner_;
  const ProcessedGroup* group_;
  const CompletionHandler* on_complete_;
};

VolumeAssembler::VolumeAssembler(std::uint32_t positions_per_volume, std::uint32_t depth)
    : depth_(depth), book_(positions_per_volume == 0 ? 1 : positions_per_volume) {
  if (positions_per_volume == 0 || depth == 0) {
    throw std::invalid_argument("VolumeAssembler: " + std::to_string(positions_per_volume) +
                                " B-scans of depth " + std::to_string(depth));
  }
}

PlacementResult VolumeAssembler::place(const ProcessedGroup& group,
                                       const CompletionHandler& on_complete) {
  if (group.depth != depth_) {
    throw std::invalid_argument("VolumeAssembler: group of depth " + std::to_string(group.depth) +
                                ", the volume's is " + std::to_string(depth_));
  }
  HostPixels pixels(*this, &group, &on_complete);
  return book_.place(std::span(group.markers.data(), group.bscan_count), group.ascans,
                     group.group_index, pixels);
}

std::optional<VolumeInfo> VolumeAssembler::seal_partial() {
  HostPixels pixels(*this, nullptr, nullptr);
  return book_.seal_partial(pixels);
}

}  // namespace ioct::gpu
