#include "ioct/gpu/live_stages/frame_publisher.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <mutex>
#include <string>
#include <utility>

#include "ioct/concurrency/monotonic_clock.hpp"

#include "forecast_wait.hpp"
#include "thread_nice.hpp"

namespace ioct::gpu::live {
namespace {

// Well inside the view's bound for a silent writer (1 s) and the 100 ms the contract asks for.
constexpr auto kHeartbeatPeriod = std::chrono::milliseconds(50);

// Bands a frame is encoded in, and the threads (the encoding one included) that encode them:
// eight bands of a 768-row render are 96 rows each; more threads than cores would only queue.
// On the H100 host a 1024 x 768 render took 2.27 ms whole, 0.88 ms in 4 bands and 0.42 ms in 8
// (ioct-bench-frame-encode, docs/BENCHMARKS.md).
constexpr unsigned kEncodeBands = 8;
// Places for views beyond which the idle ones are dropped (see publish()): more than ioct-view's
// default connection limit allows views.
constexpr std::size_t kMaxViewSlots = 128;

unsigned encode_threads() {
  return std::clamp(std::thread::hardware_concurrency(), 1u, kEncodeBands);
}

}  // namespace

FramePublisher::FramePublisher(const shm::FrameRingConfig& ring, int nice)
    : name_(ring.name),
      writer_(ring),
      // The workers encode for the encoding thread: the stages' priority, below the processing.
      encode_pool_(encode_threads(), [nice] { set_this_thread_nice(nice); }),
      render_encoder_(85, kEncodeBands, encode_pool_),
      bscan_encoder_(90, kEncodeBands, encode_pool_),
      tip_bscans_encoder_(90, kEncodeBands, encode_pool_),
      nice_(nice) {
  status_.source_state = static_cast<std::uint64_t>(shm::SourceState::waiting);
  {
    std::lock_guard lock(mutex_);
    push_status_locked();
  }
  encoder_ = std::thread([this] { encode_frames(); });
  try {
    heartbeat_ = std::thread([this] { beat(); });
  } catch (...) {
    close();  // the encoding thread is joined: a joinable thread must not be destroyed
    throw;
  }
}

void FramePublisher::set_spin_window(double spin_window_s) noexcept {
  spin_ns_.store(ioct::seconds_to_ns(spin_window_s), std::memory_order_relaxed);
}

FramePublisher::~FramePublisher() {
  close();
}

void FramePublisher::close() {
  {
    std::lock_guard lock(frame_mutex_);
    frames_stopping_ = true;
  }
  frame_wake_.notify_all();
  if (encoder_.joinable()) encoder_.join();
  {
    std::lock_guard lock(mutex_);
    if (closed_) return;
    closed_ = true;
  }
  wake_.notify_all();
  if (heartbeat_.joinable()) heartbeat_.join();
  std::lock_guard lock(mutex_);
  push_status_locked();
  writer_.close();
}

void FramePublisher::beat() {
  std::unique_lock lock(mutex_);
  while (!closed_) {
    writer_.heartbeat(ioct::monotonic_ns());
    wake_.wait_for(lock, kHeartbeatPeriod, [this] { return closed_; });
  }
}

void FramePublisher::push_status_locked() {
  writer_.set_status(status_);
}

void FramePublisher::note_group(const GroupStamp& stamp, std::uint64_t group_period_ns) {
  std::lock_guard lock(mutex_);
  status_.source_state = static_cast<std::uint64_t>(shm::SourceState::live);
  status_.groups_consumed = stamp.groups_consumed;
  status_.groups_dropped = stamp.groups_dropped;
  status_.volumes_completed = stamp.volumes_completed;
  status_.last_group_index = stamp.group_index;
  status_.last_group_published_ns = stamp.t_published_ns;
  status_.group_period_ns = group_period_ns;
  status_.ingest.record(stamp.ingest_ns);
  // Clamped: the publish time comes from another process.
  if (stamp.t_processed_ns >= stamp.t_published_ns && stamp.t_published_ns != 0) {
    status_.published_to_processed.record(stamp.t_processed_ns - stamp.t_published_ns);
  }
  push_status_locked();
}

void FramePublisher::note_pass(std::uint64_t filter_ns, std::uint64_t segmentation_ns,
                               bool rendered, std::uint64_t render_ns,
                               std::uint64_t published_to_rendered_ns) {
  std::lock_guard lock(mutex_);
  ++status_.passes;
  status_.filter.record(filter_ns);
  status_.segmentation.record(segmentation_ns);
  if (rendered) {
    status_.render.record(render_ns);
    status_.published_to_rendered.record(published_to_rendered_ns);
  }
  push_status_locked();
}

void FramePublisher::note_render_time(std::uint64_t render_ns) {
  std::lock_guard lock(mutex_);
  status_.render.record(render_ns);
  push_status_locked();
}

void FramePublisher::note_frame(std::uint64_t publish_ns) {
  std::lock_guard lock(mutex_);
  status_.publish.record(publish_ns);
  push_status_locked();
}

void FramePublisher::note_device_memory(std::uint64_t used_bytes, std::uint64_t total_bytes) {
  std::lock_guard lock(mutex_);
  status_.device_memory_known = 1;
  status_.device_memory_used_bytes = used_bytes;
  status_.device_memory_total_bytes = total_bytes;
  push_status_locked();
}

void FramePublisher::set_bscan(segmentation::RgbImage image, std::uint32_t index,
                               std::uint32_t bscans) {
  std::lock_guard lock(frame_mutex_);
  new_bscan_ = NewBscan{std::move(image), index, bscans};
}

void FramePublisher::set_tip_bscans(const instruments::TipBscans* pair) {
  std::lock_guard lock(frame_mutex_);
  new_tip_bscans_ = pair != nullptr ? *pair : instruments::TipBscans{};
}

void FramePublisher::publish(shm::FrameMeta meta, render::RgbaImage& render) {
  {
    std::lock_guard lock(frame_mutex_);
    auto slot = std::ranges::find(slots_, meta.view_id, &ViewSlot::view_id);
    if (slot == slots_.end()) {
      // A frame rendered as its view closed can make a place forget_view() never sees: the idle
      // places go when there are more than ioct-view holds views by default.
      if (slots_.size() >= kMaxViewSlots) {
        std::erase_if(slots_, [](const ViewSlot& idle) { return !idle.waiting; });
      }
      slots_.emplace_back().view_id = meta.view_id;
      slot = slots_.end() - 1;
    }
    if (slot->waiting) {
      ++replaced_;  // its place in line is kept
    } else {
      slot->waiting = true;
      slot->order = frames_came_++;
    }
    slot->meta = meta;
    std::swap(slot->image, render);
    frame_arrivals_.observe(ioct::monotonic_ns(), frames_handed_.load(std::memory_order_relaxed));
    frames_handed_.fetch_add(1, std::memory_order_release);
  }
  frame_wake_.notify_one();
  std::lock_guard lock(mutex_);
  ++status_.renders;
  push_status_locked();
}

void FramePublisher::forget_view(std::uint64_t view_id) {
  std::lock_guard lock(frame_mutex_);
  std::erase_if(slots_, [&](const ViewSlot& slot) { return slot.view_id == view_id; });
}

FramePublisher::ViewSlot* FramePublisher::next_waiting_locked() {
  ViewSlot* next = nullptr;
  for (ViewSlot& slot : slots_) {
    if (slot.waiting && (next == nullptr || slot.order < next->order)) next = &slot;
  }
  return next;
}

void FramePublisher::encode_frames() {
  set_this_thread_nice(nice_);  // encoding is the stages' work
  std::unique_lock lock(frame_mutex_);
  for (;;) {
    ViewSlot* slot = next_waiting_locked();
    while (slot == nullptr && !frames_stopping_) {
      wait_for_next(lock, frame_wake_, frame_arrivals_, frames_handed_,
                    spin_ns_.load(std::memory_order_relaxed), UINT64_MAX);
      slot = next_waiting_locked();
    }
    if (slot == nullptr) return;  // stopping, with nothing left to write
    std::swap(slot->image, encoding_);
    const shm::FrameMeta meta = slot->meta;
    slot->waiting = false;
    std::optional<NewBscan> bscan = std::exchange(new_bscan_, std::nullopt);
    std::optional<instruments::TipBscans> tip_bscans = std::exchange(new_tip_bscans_, std::nullopt);
    lock.unlock();
    const std::uint64_t started_ns = ioct::monotonic_ns();
    try {
      write_frame(meta, encoding_, bscan ? &*bscan : nullptr, tip_bscans ? &*tip_bscans : nullptr);
    } catch (const std::exception& e) {
      // A frame that cannot be encoded, or is too large for the ring, costs the viewers that
      // frame, never the pipeline.
      std::lock_guard counts(mutex_);
      ++frame_counts_.errors;
      frame_counts_.problem = e.what();
    }
    note_frame(ioct::monotonic_ns() - started_ns);
    lock.lock();
  }
}

void FramePublisher::write_frame(shm::FrameMeta meta, const render::RgbaImage& render,
                                 const NewBscan* bscan, const instruments::TipBscans* tip_bscans) {
  // The render and the pictures new with it, cut into bands that share one run of the pool (the
  // render's first): a frame that brings a new B-scan does not wait for the B-scan's encoding
  // before its own begins. A picture that cannot be encoded is shown as none from then on, never
  // an older one as if it were new; a render that cannot be encoded costs the viewers this frame.
  struct Picture {
    const char* name;
    BandedJpegEncoder* encoder;
    std::uint32_t bands;
    bool failed = false;
  };
  std::array<Picture, 3> pictures{};
  std::size_t count = 0;
  pictures[count++] = {
      "render", &render_encoder_,
      render_encoder_.cut(render.rgba, render.width, render.height, PixelLayout::rgba)};
  Picture* bscan_picture = nullptr;
  if (bscan != nullptr) {
    const segmentation::RgbImage& image = bscan->image;
    bscan_picture = &pictures[count];
    pictures[count++] = {
        "B-scan", &bscan_encoder_,
        bscan_encoder_.cut(image.pixels, image.width, image.height, PixelLayout::rgb)};
  }
  Picture* tip_picture = nullptr;
  if (tip_bscans != nullptr && tip_bscans->width != 0 && tip_bscans->height != 0) {
    tip_picture = &pictures[count];
    pictures[count++] = {"tip B-scan pair", &tip_bscans_encoder_,
                         tip_bscans_encoder_.cut(tip_bscans->pixels, tip_bscans->stride(),
                                                 tip_bscans->height, PixelLayout::gray)};
  }
  std::mutex failures;  // the pool's threads report here
  std::string problem;  // the first failure
  const auto fail = [&](Picture& picture, const std::exception& e) {
    std::lock_guard lock(failures);
    picture.failed = true;
    if (problem.empty()) problem = std::string(picture.name) + ": " + e.what();
  };
  std::uint32_t bands = 0;
  for (std::size_t i = 0; i < count; ++i) bands += pictures[i].bands;
  encode_pool_.run(bands, [&](std::uint32_t band, unsigned) {
    for (std::size_t i = 0; i < count; ++i) {
      if (band < pictures[i].bands) {
        try {
          pictures[i].encoder->encode_band(band);
        } catch (const std::exception& e) {
          fail(pictures[i], e);
        }
        return;
      }
      band -= pictures[i].bands;
    }
  });
  const auto joined = [&](Picture* picture) -> std::span<const std::byte> {
    if (picture == nullptr || picture->failed) return {};
    try {
      return picture->encoder->joined();
    } catch (const std::exception& e) {
      fail(*picture, e);
      return {};
    }
  };
  const std::span<const std::byte> jpeg = joined(&pictures[0]);
  std::lock_guard lock(mutex_);
  if (bscan != nullptr) {
    const std::span<const std::byte> bscan_jpeg = joined(bscan_picture);
    bscan_jpeg_.assign(bscan_jpeg.begin(), bscan_jpeg.end());
    bscan_width_ = bscan_jpeg.empty() ? 0 : bscan->image.width;
    bscan_height_ = bscan_jpeg.empty() ? 0 : bscan->image.height;
    bscan_index_ = bscan->index;
    bscans_ = bscan->bscans;
  }
  if (tip_bscans != nullptr) {  // a new pair, or none any more
    const std::span<const std::byte> pair_jpeg = joined(tip_picture);
    tip_bscans_jpeg_.assign(pair_jpeg.begin(), pair_jpeg.end());
    tip_bscan_width_ = pair_jpeg.empty() ? 0 : tip_bscans->width;
    tip_bscan_height_ = pair_jpeg.empty() ? 0 : tip_bscans->height;
  }
  if (!problem.empty()) {
    ++frame_counts_.errors;
    frame_counts_.problem = problem;
  }
  if (pictures[0].failed || closed_) return;
  meta.format = static_cast<std::uint32_t>(shm::FrameFormat::jpeg);
  meta.width = render.width;
  meta.height = render.height;
  meta.bscan_width = bscan_width_;
  meta.bscan_height = bscan_height_;
  meta.bscan_index = bscan_index_;
  meta.bscans = bscans_;
  meta.tip_bscan_width = tip_bscan_width_;
  meta.tip_bscan_height = tip_bscan_height_;
  writer_.publish(meta, jpeg, bscan_jpeg_, tip_bscans_jpeg_);  // throws for a frame too large
  ++frame_counts_.written;
}

FramePublisher::FrameCounts FramePublisher::frame_counts() const {
  std::uint64_t replaced = 0;
  {
    std::lock_guard lock(frame_mutex_);
    replaced = replaced_;
  }
  std::lock_guard lock(mutex_);
  FrameCounts counts = frame_counts_;
  counts.replaced = replaced;
  return counts;
}

}  // namespace ioct::gpu::live
