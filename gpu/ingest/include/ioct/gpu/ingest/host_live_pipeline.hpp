// The live pipeline through host memory: each group is copied out of the ring with read_next(),
// processed by an OctProcessor and placed by a VolumeAssembler, one group at a time. The path of
// the CPU backend.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "ioct/gpu/ingest/live_pipeline.hpp"
#include "ioct/gpu/volume/volume_assembler.hpp"

namespace ioct::gpu {

class HostLivePipeline final : public LivePipeline {
 public:
  // `processor` is prepared here for the ring's geometry.
  HostLivePipeline(std::unique_ptr<OctProcessor> processor, std::uint32_t repeats_per_position,
                   shm::RingReader reader);

  shm::PollStatus poll(LiveEvents& events) override;
  void drain(LiveEvents&) override {}
  std::optional<VolumeInfo> seal_partial(const Volume*& volume) override;
  LiveVolumeShape shape() const override;
  void copy_bscans(std::uint32_t first, std::uint32_t count, Volume& out) override;
  const shm::RingReader& reader() const noexcept override { return reader_; }
  void set_db_range(const DbScaleConfig& scale) override { processor_->set_db_range(scale); }
  std::string_view backend_name() const noexcept override { return processor_->backend_name(); }

 private:
  void handle_group(const shm::SlotHeader& header, LiveEvents& events);

  shm::RingReader reader_;
  shm::RingGeometry geometry_;
  std::unique_ptr<OctProcessor> processor_;
  std::uint32_t repeats_;
  VolumeAssembler assembler_;
  std::vector<std::uint16_t> spectra_;  // one group, read into by read_next()
  ProcessedGroup processed_;
  std::optional<std::uint64_t> last_epoch_;
};

}  // namespace ioct::gpu
