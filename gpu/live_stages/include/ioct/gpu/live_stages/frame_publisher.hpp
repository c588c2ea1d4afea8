// The frames for viewers: each render of a view, encoded as JPEG together with the current B-scan,
// published into the frame ring (shm/frame_ring.hpp) that ioct-view reads; and the pipeline's
// status and the writer's heartbeat in the ring's header.
//
// The heartbeat has a thread of its own, beating every 50 ms whatever the stages are doing (a CPU
// pass can take seconds): the view tells a silent writer (NO SIGNAL) from a slow one by it. The
// status is set from the live loop at every group, so "no new group" (STALE) is seen as soon as it
// happens, and the stages' times (histograms, shm/stage_histogram.hpp) with it, for /metrics.
// All calls into the ring go through one mutex, held only for the copy into the ring.
//
// Frames are encoded on a thread of the publisher's own: publish() hands the pixels over and
// returns, so the stages never wait for JPEG (a group that arrives while a turning view's frame
// is being encoded is not held up by it). One frame per view waits at most, a newer frame of the
// same view replaces it, and the views' frames are encoded in the order they came.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "ioct/concurrency/arrival_forecast.hpp"
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
  // the heartbeat and the encoding thread, the latter at `nice` (the stages' own, 0-19: encoding
  // is the stages' work, below the processing). The encoding thread waits asleep until
  // set_spin_window says otherwise.
  explicit FramePublisher(const shm::FrameRingConfig& ring, int nice = 0);
  // From the next frame on, the encoding thread waits awake within `spin_window_s` of when the
  // next frame is due (forecast from the last ones; 0: asleep only): the stages set it once they
  // know whether a GPU renders.
  void set_spin_window(double spin_window_s) noexcept;
  ~FramePublisher();  // close()
  FramePublisher(const FramePublisher&) = delete;
  FramePublisher& operator=(const FramePublisher&) = delete;

  // The B-scan sent with the following frames (publishing thread): encoded once, on the encoding
  // thread before its next frame, since it changes only with a pass or the chosen position.
  // `image` is the B-scan with depth downwards.
  void set_bscan(segmentation::RgbImage image, std::uint32_t index, std::uint32_t bscans);
  // The B-scan pair through the instrument's tip sent with the following frames (publishing
  // thread), encoded once as the B-scan is; null: none (no instrument, or detection off).
  void set_tip_bscans(const instruments::TipBscans* pair);

  // Hands `render` to the encoding thread, which encodes it and publishes it with the B-scan
  // current then, and returns at once (publishing thread). Takes the pixels: `render` is left
  // with another buffer, of no particular content. `meta` gives the view, generation, group
  // stamp, times and mode; the sizes are filled in there. Counts a render.
  void publish(shm::FrameMeta meta, render::RgbaImage& render);

  // A private view is closed (any thread): its waiting frame and its place go.
  void forget_view(std::uint64_t view_id);

  // What became of the frames handed over: written into the ring, replaced by a newer frame of
  // the same view before their turn, or not written (refused by the ring as too large, or their
  // encoding failed: not fatal, the viewers miss that frame).
  struct FrameCounts {
    std::uint64_t written = 0, replaced = 0, errors = 0;
    std::string problem;  // the last failure
  };
  FrameCounts frame_counts() const;

  // The newest group handed to the stages (any thread): the books, its ingest time and its
  // publish -> processed latency.
  void note_group(const GroupStamp& stamp, std::uint64_t group_period_ns);
  // A pass's stage times; the render's and the publish -> rendered latency of its newest group
  // only when it rendered.
  void note_pass(std::uint64_t filter_ns, std::uint64_t segmentation_ns, bool rendered,
                 std::uint64_t render_ns, std::uint64_t published_to_rendered_ns);
  // A render between passes (interaction, rotation, private views).
  void note_render_time(std::uint64_t render_ns);
  // A frame written: its encoding (with the B-scans that changed) and copy into the ring took
  // `publish_ns` on the encoding thread.
  void note_frame(std::uint64_t publish_ns);
  // Device memory in use and in all (the CUDA backend; never called on the CPU backend).
  void note_device_memory(std::uint64_t used_bytes, std::uint64_t total_bytes);

  // Writes the frame still waiting, stops the encoding thread and the heartbeat, and marks the
  // ring closed (ioct-view then shows NO SIGNAL at once).
  void close();

  const std::string& name() const noexcept { return name_; }

 private:
  void beat();
  void encode_frames();
  void push_status_locked();

  std::string name_;
  mutable std::mutex mutex_;  // the writer, status_, the B-scans' JPEGs and frame_counts_
  std::condition_variable wake_;
  shm::FrameRingWriter writer_;
  shm::FrameRingStatus status_{};
  bool closed_ = false;
  FrameCounts frame_counts_;

  // The encoding thread's. A frame is encoded in bands on a few threads: on one core the
  // 1024 x 768 render took about 3 ms of the ~5 between a group's publish and its frame.
  WorkerPool encode_pool_;
  BandedJpegEncoder render_encoder_;
  BandedJpegEncoder bscan_encoder_;
  BandedJpegEncoder tip_bscans_encoder_;
  // The encoded B-scan and tip pair sent with each frame (under mutex_).
  std::vector<std::byte> bscan_jpeg_;
  std::uint32_t bscan_width_ = 0, bscan_height_ = 0, bscan_index_ = 0, bscans_ = 0;
  std::vector<std::byte> tip_bscans_jpeg_;
  std::uint32_t tip_bscan_width_ = 0, tip_bscan_height_ = 0;

  // What waits for the encoding thread (under frame_mutex_): each view's newest frame, in a slot
  // of its own that keeps its buffer (the pixels go round between the stages' image, the slot and
  // the one being encoded, with no allocation), and a new B-scan or tip pair to encode before the
  // next frame.
  struct ViewSlot {
    std::uint64_t view_id = 0;
    bool waiting = false;
    std::uint64_t order = 0;  // when its frame came, for first come, first encoded
    shm::FrameMeta meta{};
    render::RgbaImage image;
  };
  struct NewBscan {
    segmentation::RgbImage image;
    std::uint32_t index = 0, bscans = 0;
  };
  mutable std::mutex frame_mutex_;
  std::condition_variable frame_wake_;
  std::vector<ViewSlot> slots_;  // one per open view (views are few: ioct-view limits them)
  std::uint64_t frames_came_ = 0;
  std::atomic<std::uint64_t> frames_handed_{0};  // every frame handed over, replaced or not
  ArrivalForecast frame_arrivals_;
  std::atomic<std::uint64_t> spin_ns_{0};
  std::uint64_t replaced_ = 0;
  bool frames_stopping_ = false;
  render::RgbaImage encoding_;
  std::optional<NewBscan> new_bscan_;
  std::optional<instruments::TipBscans> new_tip_bscans_;  // an empty pair: none
  int nice_ = 0;
  ViewSlot* next_waiting_locked();
  // Encodes the frame with the B-scan and tip pair new with it (null: unchanged; a pair of no
  // pixels: none any more) and writes it to the ring. A picture that cannot be encoded is counted
  // and shown as none; a render that cannot be, counted and not written.
  void write_frame(shm::FrameMeta meta, const render::RgbaImage& render, const NewBscan* bscan,
                   const instruments::TipBscans* tip_bscans);

  std::thread heartbeat_;
  std::thread encoder_;
};

}  // namespace ioct::gpu::live
