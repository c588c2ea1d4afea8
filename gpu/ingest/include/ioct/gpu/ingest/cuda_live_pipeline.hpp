// The live pipeline of the cuda backend: ring -> GPU -> live volume on the GPU.
//
// Ingest: the reader's whole read-only ring mapping is registered with
// cudaHostRegister(cudaHostRegisterReadOnly), so a slot is copied to the device by DMA at the
// PCIe rate with no staging copy. For each group: begin_read() -> cudaMemcpyAsync(slot -> a raw
// buffer on the device) on the copy stream -> when that copy has completed, end_read() re-checks
// the slot's sequence: a lapped copy is discarded (the reader counts the drop) and never
// processed; an intact one is processed on the processing stream. The next copy is issued before
// the processing of the group just verified is enqueued, so the copy engine moves group g + 1
// while the SMs process group g (and g - 1 may still be finishing): `groups_in_flight` raw
// buffers (3 by default) go round, each reused only after the processing that read it is done.
// The ring API lets one ticket be out at a time, so copies are one after another with a short
// host round trip between them, not queued back to back.
//
// The volume lives on the device: positions x width x depth u8, written in place group by group
// on the processing stream (placement by VolumeBook, the same rules as the CPU path; gaps zeroed
// at completion). Each completed volume is copied, on the same stream, straight into a host
// Volume whose memory is registered with CUDA (when host volumes are wanted, e.g. for PNG files)
// and handed to on_volume() once the group that completed it has landed, after that group's
// on_group() (the stages take the group first). When one group
// completes several volumes (volumes shorter than a group), each is copied and handed out.
//
// Readers of the device volume (renderers) see it only as of a whole number of groups
// ("per-group versions"): read_volume() makes their stream wait for every group enqueued so far
// and makes the next group's writes wait for their reads, so no read ever meets a half-written
// group, and a read costs the processing nothing unless it overlaps the next group's writes.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "ioct/gpu/ingest/live_pipeline.hpp"

struct CUstream_st;

namespace ioct::gpu {

class CudaLivePipeline final : public LivePipeline {
 public:
  // Prepares the chain for the ring's geometry, registers the mapping, allocates everything.
  // Throws BackendUnavailable (no usable GPU), ConfigError, std::invalid_argument (geometry),
  // std::runtime_error naming a failed CUDA call.
  CudaLivePipeline(const OctProcessorConfig& config, shm::RingReader reader,
                   const LivePipelineOptions& options = {});
  ~CudaLivePipeline() override;

  shm::PollStatus poll(LiveEvents& events) override;
  void drain(LiveEvents& events) override;
  std::optional<VolumeInfo> seal_partial(const Volume*& volume) override;
  LiveVolumeShape shape() const override;
  // Through read_volume() on a stream of its own, synchronously.
  void copy_bscans(std::uint32_t first, std::uint32_t count, Volume& out) override;
  const shm::RingReader& reader() const noexcept override;
  void set_db_range(const DbScaleConfig& scale) override;
  std::string_view backend_name() const noexcept override { return "cuda"; }

  // Enqueues a reader's work on `stream`: `enqueue_reads` is called at once with the view and
  // must only enqueue work on `stream` (kernels, copies) that reads the volume. See above.
  void read_volume(CUstream_st* stream,
                   const std::function<void(const DeviceVolumeView&)>& enqueue_reads);
  // The same, for stages (LiveVolumeSource); always true here.
  bool read_on_device(CUstream_st* stream,
                      const std::function<void(const DeviceVolumeView&)>& enqueue_reads) override;

  // How the ring mapping is registered ("registered read-only", or the fallback and why).
  const std::string& ingest_note() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ioct::gpu
