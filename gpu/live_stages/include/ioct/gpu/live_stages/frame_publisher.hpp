// The frames for viewers: each render of a view, encoded as JPEG together with the current B-scan,
// published into the frame ring (shm/frame_ring.hpp) that ioct-view reads; and the pipeline's
// status and the writer's heartbeat in the ring's header.
//
// The heartbeat has a thread of its own, beating every 50 ms whatever the stages are doing (a CPU
// pass can take seconds): the view tells a silent writer (NO SIGNAL) from a slow one by it. The
// status is set from the live loop at every group, so "no new group" (STALE) is seen as soon as it
// happens, and the stages' times (histograms, shm/stage_histogram.hpp) with it, for /metrics.
// All calls into the ring go through one mutex, held only for the copy into the ring.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "ioct/gpu/ingest/live_stage.hpp"
#include "ioct/gpu/instruments/tip_bscans.hpp"
#include "ioct/gpu/live_stages/banded_jpeg_encoder.hpp"
#include "ioct/gpu/render/rgba_image.hpp"
#include "ioct/gpu/segmentation/overlay_image.hpp"
#include "ioct/shm/frame_ring.hpp"

namespace ioct::gpu::live {

class FramePublisher {
 public:
  // Creates the frame ring (shm::RingError when another live writer holds the name) and starts
  // the heartbeat.
  explicit FramePublisher(const shm::FrameRingConfig& ring);
  ~FramePublisher();  // close()
  FramePublisher(const FramePublisher&) = delete;
  FramePublisher& operator=(const FramePublisher&) = delete;

  // The B-scan sent with the following frames (publishing thread): encoded once here, since it
  // changes only with a pass or the chosen position. `image` is the B-scan with depth downwards.
  void set_bscan(const segmentation::RgbImage& image, std::uint32_t index, std::uint32_t bscans);
  // The B-scan pair through the instrument's tip sent with the following frames (publishing
  // thread), encoded once here; null: none (no instrument, or detection off).
  void set_tip_bscans(const instruments::TipBscans* pair);

  // Encodes `render` and publishes it with the current B-scan (publishing thread). `meta` gives
  // the view, generation, group stamp, times and mode; the sizes are filled in here. Returns the
  // frame index.
  std::uint64_t publish(shm::FrameMeta meta, const render::RgbaImage& render);

  // The newest group handed to the stages (any thread): the books, its ingest time and its
  // publish -> processed latency.
  void note_group(const GroupStamp& stamp, std::uint64_t group_period_ns);
  // A pass's stage times; the render's and the publish -> rendered latency of its newest group
  // only when it rendered.
  void note_pass(std::uint64_t filter_ns, std::uint64_t segmentation_ns, bool rendered,
                 std::uint64_t render_ns, std::uint64_t published_to_rendered_ns);
  // A render between passes (interaction, rotation, private views).
  void note_render_time(std::uint64_t render_ns);
  // A frame published: its encoding and copy into the ring took `publish_ns`.
  void note_frame(std::uint64_t publish_ns);
  // Device memory in use and in all (the CUDA backend; never called on the CPU backend).
  void note_device_memory(std::uint64_t used_bytes, std::uint64_t total_bytes);

  // Stops the heartbeat and marks the ring closed (ioct-view then shows NO SIGNAL at once).
  void close();

  const std::string& name() const noexcept { return name_; }

 private:
  void beat();
  void push_status_locked();

  std::string name_;
  std::mutex mutex_;  // the writer and status_
  std::condition_variable wake_;
  shm::FrameRingWriter writer_;
  shm::FrameRingStatus status_{};
  bool closed_ = false;

  // The publishing thread's own. A frame is encoded in bands on a few threads: on one core the
  // 1024 x 768 render took about 3 ms of the ~5 between a group's publish and its frame.
  WorkerPool encode_pool_;
  BandedJpegEncoder render_encoder_;
  BandedJpegEncoder bscan_encoder_;
  std::vector<std::byte> bscan_jpeg_;
  std::uint32_t bscan_width_ = 0, bscan_height_ = 0, bscan_index_ = 0, bscans_ = 0;
  BandedJpegEncoder tip_bscans_encoder_;
  std::vector<std::byte> tip_bscans_jpeg_;
  std::uint32_t tip_bscan_width_ = 0, tip_bscan_height_ = 0;

  std::thread heartbeat_;
};

}  // namespace ioct::gpu::live
