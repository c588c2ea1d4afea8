#include "ioct/gpu/ingest/host_live_pipeline.hpp"

#include <algorithm>

#include "ioct/gpu/processing/group_check.hpp"

namespace ioct::gpu {

HostLivePipeline::HostLivePipeline(std::unique_ptr<OctProcessor> processor,
                                   std::uint32_t repeats_per_position, shm::RingReader reader)
    : reader_(std::move(reader)),
      geometry_(reader_.geometry()),
      processor_(std::move(processor)),
      repeats_(repeats_per_position),
      assembler_(geometry_.bscans_per_volume / repeats_per_position, depth_of(geometry_)),
      spectra_((reader_.layout().group_payload_bytes + 1) / 2) {
  processor_->prepare(geometry_);
  processed_.pixels.reserve(std::size_t{geometry_.bscans_per_group} * geometry_.ascans_per_bscan *
                            depth_of(geometry_));
}

shm::PollStatus HostLivePipeline::poll(LiveEvents& events) {
  const std::span<std::byte> buffer(reinterpret_cast<std::byte*>(spectra_.data()),
                                    reader_.layout().group_payload_bytes);
  shm::SlotHeader header;
  const shm::PollStatus status = reader_.read_next(buffer, header);
  if (status == shm::PollStatus::ready) handle_group(header, events);
  return status == shm::PollStatus::lapped ? shm::PollStatus::ready : status;
}

void HostLivePipeline::handle_group(const shm::SlotHeader& header, LiveEvents& events) {
  if (last_epoch_ && *last_epoch_ != header.producer_epoch) events.on_restart(assembler_.reset());
  last_epoch_ = header.producer_epoch;
  if (auto problem =
          find_group_problem(header, geometry_, reader_.layout().group_payload_bytes, repeats_)) {
    events.on_rejected(header, *problem);
    return;
  }
  processor_->process(RawGroup{header, std::span<const std::uint16_t>(spectra_)}, processed_);
  const PlacementResult placed = assembler_.place(
      processed_, [&](const Volume& v, const VolumeInfo& info) { events.on_volume(v, info); });
  events.on_group(header, placed);
}

std::optional<VolumeInfo> HostLivePipeline::seal_partial(const Volume*& volume) {
  const std::optional<VolumeInfo> info = assembler_.seal_partial();
  volume = info ? &assembler_.volume() : nullptr;
  return info;
}

LiveVolumeShape HostLivePipeline::shape() const {
  const Volume& live = assembler_.volume();
  return {live.bscans(), live.ascans(), live.depth()};
}

void HostLivePipeline::copy_bscans(std::uint32_t first, std::uint32_t count, Volume& out) {
  const Volume& live = assembler_.volume();
  prepare_bscan_copy(shape(), first, count, out);
  if (count == 0) return;
  std::ranges::copy(live.pixels().subspan(first * live.bscan_pixels(), count * live.bscan_pixels()),
                    out.bscan(first).begin());
}

}  // namespace ioct::gpu
