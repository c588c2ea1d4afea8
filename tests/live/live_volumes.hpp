// The live volume the stages' tests hand over: a fake LiveVolumeSource (layered_volume.hpp has
// the speckled layered volume they fill it with).
#pragma once

#include <algorithm>
#include <cmath>
#include <random>

#include "ioct/gpu/ingest/live_stage.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "layered_volume.hpp"

namespace ioct::gpu::live {

// A live volume the test writes into: copy_bscans as the pipelines do it.
class FakeLiveVolume final : public LiveVolumeSource {
 public:
  Volume volume;
  LiveVolumeShape shape() const override {
    return {volume.bscans(), volume.ascans(), volume.depth()};
  }
  void copy_bscans(std::uint32_t first, std::uint32_t count, Volume& out) override {
    prepare_bscan_copy(shape(), first, count, out);
    const std::size_t n = volume.bscan_pixels();
    std::copy_n(volume.bscan(first).data(), count * n, out.bscan(first).data());
  }
};

}  // namespace ioct::gpu::live
