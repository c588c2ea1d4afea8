// What the live loop drives: groups from the ring in, B-scans placed into the live volume and
// completed volumes out. Two implementations:
//   HostLivePipeline  - read_next() into host memory, an OctProcessor (the CPU one), a host
//                       VolumeAssembler; one group at a time.
//   CudaLivePipeline  - the ring mapping registered with CUDA, cudaMemcpyAsync straight from the
//                       slot, several groups in flight, the volume on the device
//                       (cuda_live_pipeline.hpp).
// LiveProcessor owns one and does the rest (status, latency, images, summary).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "ioct/gpu/ingest/live_stage.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_book.hpp"
#include "ioct/shm/ring_reader.hpp"

namespace ioct::gpu {

// What a pipeline reports, in the order things happened.
class LiveEvents {
 public:
  virtual ~LiveEvents() = default;
  // A completed volume, as a host copy (the pipeline keeps it). Called beside on_group() of the
  // group that completed it: before it on the host pipeline (the volume is overwritten by the
  // group's later B-scans), after it on the device pipeline (the copy is the pipeline's own, so
  // the group is not held up by what is done with the volume).
  virtual void on_volume(const Volume& volume, const VolumeInfo& info) = 0;
  // The group's B-scans are in the live volume (`placed` says how they fared).
  virtual void on_group(const shm::SlotHeader& header, const PlacementResult& placed) = 0;
  // The group was read intact but its header does not fit the geometry: not processed.
  virtual void on_rejected(const shm::SlotHeader& header, const std::string& problem) = 0;
  // The producer restarted (a new epoch): the volume in progress was forgotten, and abandoned
  // when it held B-scans.
  virtual void on_restart(bool volume_abandoned) = 0;
};

class LivePipeline : public LiveVolumeSource {
 public:
  // Moves work along without waiting long: reads what the ring has ready, finishes what the
  // processing has done. Returns ready when anything is under way or happened (call again soon),
  // empty when there is nothing to do, producer_gone when the producer closed the ring and
  // everything it published has been dealt with.
  virtual shm::PollStatus poll(LiveEvents& events) = 0;

  // Finishes everything in flight (at the end of a run).
  virtual void drain(LiveEvents& events) = 0;

  // Zeroes the positions not yet placed in the volume in progress and returns a host copy of it,
  // for showing a partial volume when the stream ends; nothing when no B-scan is in progress.
  // Call after drain().
  virtual std::optional<VolumeInfo> seal_partial(const Volume*& volume) = 0;

  virtual const shm::RingReader& reader() const noexcept = 0;
  // The dB range of the groups processed from now on (OctProcessor::set_db_range).
  virtual void set_db_range(const DbScaleConfig& scale) = 0;
  virtual std::string_view backend_name() const noexcept = 0;
};

struct LivePipelineOptions {
  // Copy each completed volume to the host for on_volume(). Off, the device pipeline never
  // copies volumes back (benchmarks), and on_volume() is not called.
  bool host_volumes = true;
  // CUDA: groups in flight (raw group buffers on the device), at least 2.
  std::uint32_t groups_in_flight = 3;
};

// The pipeline of `backend` (cpu or cuda; resolve automatic first) reading from `reader`.
// Throws BackendUnavailable, ConfigError, std::invalid_argument for a geometry the chain cannot
// process.
std::unique_ptr<LivePipeline> make_live_pipeline(Backend backend, const OctProcessorConfig& config,
                                                 shm::RingReader reader,
                                                 const LivePipelineOptions& options = {});

}  // namespace ioct::gpu
