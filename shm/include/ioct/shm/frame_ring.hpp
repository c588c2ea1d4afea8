// The frame ring: rendered frames from ioct-gpu (one writer) to ioct-view (readers), the only
// contract between the pipeline and the process that faces the network.
//
// The same discipline as the group ring, smaller: one writer that never waits, slots under a
// seqlock, readers that map read-only and find out afterwards whether the writer lapped them.
// Latest wins: a reader that falls behind skips to the newest frames; nothing here ever waits for
// a viewer. Besides the frames the header carries the writer's heartbeat and the pipeline's
// status (the producer's state, the newest group, drops), so a viewer can tell "no new group for a
// while" (STALE) from "the pipeline is gone" (NO SIGNAL) without a second channel.
//
// Layout: FrameRingHeader (page 0), then `slot_count` slots of `slot_stride` bytes, each a
// FrameSlotHeader (sequence word, FrameMeta) followed by the payload at a page boundary.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "ioct/shm/shm_object.hpp"
#include "ioct/shm/stage_histogram.hpp"

namespace ioct::shm {

inline constexpr std::uint64_t kFrameRingMagic = 0x454D'4152'4654'4F49;  // "IOTFRAME" (LE)
// 2: FrameRingStatus carries the stage times, latencies and device memory.
// 3: FrameMeta carries the instrument finding of the volume state it shows, and the payload the
//    B-scan pair through the instrument's tip.
// 4: FrameRingHeader::frame_signal, the word readers sleep on until the next frame.
inline constexpr std::uint32_t kFrameRingVersion = 4;
inline constexpr std::uint32_t kMaxFrameSlots = 64;
inline constexpr std::uint64_t kMaxFramePayloadBytes = 64ull << 20;  // a 4K stereo JPEG is < 8 MiB
inline constexpr std::size_t kFrameModeNameBytes = 24;

enum class FrameFormat : std::uint32_t { jpeg = 1 };

// What the writer knows of the group ring it reads (FrameRingStatus::source_state).
enum class SourceState : std::uint32_t {
  waiting = 0,        // no producer ring yet (ioct-rt not running), or not attached yet
  live = 1,           // attached, groups arriving
  producer_gone = 2,  // the producer closed or left its ring; the writer waits for it
};

// Instrument detection in the volume state a frame shows (FrameInstrument::state).
enum class FrameInstrumentState : std::uint32_t {
  off = 0,    // ioct-gpu runs without instrument detection
  none = 1,   // detection runs and found no instrument
  found = 2,  // the instrument nearest to the RPE is described
};

// Where the surfaces at the tip came from (FrameInstrument::distance_source).
enum class FrameDistanceSource : std::uint32_t {
  none = 0,      // no segmented surface near the tip: no distances
  measured = 1,  // the tip's own A-scan, segmented
  inferred = 2,  // under the tool: carried from the nearest measured A-scans
};

// The instrument a frame shows with its picture, so the distance and the picture always belong
// to the same volume state. Distances in um of the depth axis, positive when the tip is above the
// surface; NaN when unknown.
struct FrameInstrument {
  std::uint32_t state;            // FrameInstrumentState
  std::uint32_t distance_source;  // FrameDistanceSource
  std::uint32_t warning;          // 1: the tip is within warn_rpe_um of the RPE
  std::uint32_t translucent;      // 1: a translucent tool (the tip's A-scans partly shadowed)
  std::uint32_t instruments;      // instruments found; the one nearest to the RPE is described
  float warn_rpe_um;              // the warning distance ioct-gpu was given
  float tip_voxel[3];             // B-scan, A-scan, depth px (fractional)
  float tip_um[3];                // x along a B-scan, y across B-scans, z in depth
  float to_ilm_um;
  float to_rpe_um;
  // Where the tip appears in the frame's render, px of the output image (per eye; the right
  // eye's to the right of the left's); NaN where it does not (outside, or a planar mode).
  float render_x[2];
  float render_y[2];
};

// One frame's description. Trivially copyable; copied out whole by readers.
struct FrameMeta {
  std::uint64_t frame_index;           // set by the writer: 0, 1, 2, ... per writer epoch
  std::uint64_t view_id;               // 0: the shared (operator's) view; others: a viewer's own
  std::uint64_t params_generation;     // the render parameters' generation this frame shows
  std::uint64_t group_index;           // newest ring group in the volume state shown
  std::uint64_t volume_index;          // that group's volume
  std::uint64_t t_group_published_ns;  // CLOCK_MONOTONIC, from the group's slot header
  std::uint64_t t_group_processed_ns;  // the group placed into the live volume
  std::uint64_t t_rendered_ns;         // the render finished (before encoding)
  std::uint64_t t_written_ns;          // set by the writer: the frame published here
  std::uint32_t format;                // FrameFormat
  std::uint32_t width;                 // the render, px (stereo: both eyes side by side)
  std::uint32_t height;
  std::uint32_t render_bytes;  // payload [0, render_bytes): the render, encoded
  std::uint32_t bscan_bytes;   // payload [render_bytes, + bscan_bytes): the B-scan, or 0
  std::uint32_t bscan_width;   // A-scans
  std::uint32_t bscan_height;  // depth px
  std::uint32_t bscan_index;   // which B-scan of the volume (its position, 0 = first)
  std::uint32_t bscans;        // B-scans in the volume
  std::uint32_t stereo;        // 1: left | right eye side by side
  // payload [render_bytes + bscan_bytes, + tip_bscans_bytes): the B-scan pair through the
  // instrument's tip (along | across its axis, side by side, the tip in each half's centre
  // column), encoded; 0 bytes without an instrument. Each half tip_bscan_width x tip_bscan_height.
  std::uint32_t tip_bscans_bytes;
  std::uint32_t tip_bscan_width;
  std::uint32_t tip_bscan_height;
  std::uint32_t reserved_meta;
  char mode[kFrameModeNameBytes];  // render mode name, NUL-terminated ("enhanced", ...)
  FrameInstrument instrument;
};

// The pipeline's figures as the writer last reported them (FrameRingWriter::set_status).
struct FrameRingStatus {
  std::uint64_t source_state;     // SourceState
  std::uint64_t groups_consumed;  // ring groups read intact
  std::uint64_t groups_dropped;   // lapped + behind
  std::uint64_t volumes_completed;
  std::uint64_t last_group_index;         // newest group processed
  std::uint64_t last_group_published_ns;  // its publish time (CLOCK_MONOTONIC); 0: none yet
  std::uint64_t group_period_ns;          // measured between groups; 0: not known yet
  std::uint64_t passes;                   // live-stage passes (filter, segment, render)
  std::uint64_t renders;                  // frames rendered (all views)
  // The stages' times, each from its start to its end (ioct-view serves them as /metrics).
  StageHistogram ingest;        // the live loop's part of a group: read, process, place
  StageHistogram filter;        // per pass
  StageHistogram segmentation;  // per pass
  StageHistogram render;        // per render, all views
  StageHistogram publish;       // a frame encoded and written into this ring
  // Latencies from the group's publication by ioct-rt (its slot header's time).
  StageHistogram published_to_processed;  // placed into the live volume
  StageHistogram published_to_rendered;   // rendered by the pass that took it
  // Device memory as the CUDA backend last saw it; known = 0 on the CPU backend.
  std::uint64_t device_memory_known;
  std::uint64_t device_memory_used_bytes;
  std::uint64_t device_memory_total_bytes;
};

struct FrameRingHeader {
  std::uint64_t magic;  // written last at creation
  std::uint32_t layout_version;
  std::uint32_t slot_count;
  std::uint64_t header_bytes;
  std::uint64_t slot_stride;
  std::uint64_t max_payload_bytes;
  std::uint64_t writer_pid;
  std::uint64_t writer_start_ticks;
  // Live words (atomic access only).
  std::uint64_t epoch;      // a new writer (restart) takes a new epoch
  std::uint64_t closed;     // 1 once the writer closed it on an orderly exit
  std::uint64_t published;  // frames published in this epoch
  // Bumped after each frame and at close; readers sleep on it (a shared futex) instead of polling.
  std::uint32_t frame_signal;
  std::uint32_t reserved;
  std::uint64_t heartbeat_ns;     // CLOCK_MONOTONIC; the writer beats while alive, frames or not
  std::uint64_t status_sequence;  // seqlock of `status`: odd while it is written
  FrameRingStatus status;
};

struct FrameSlotHeader {
  std::uint64_t sequence;  // 2f+1 while frame f is written, 2f+2 once published
  std::uint64_t reserved[7];
  FrameMeta meta;
};

struct FrameRingConfig {
  std::string name;  // shm object name, e.g. "<ring>.frames"
  std::uint32_t slots = 8;
  std::uint64_t max_payload_bytes = 8ull << 20;
  unsigned mode = 0640;  // the writer writes, the view's group reads
  std::string group;     // owning group; empty: the writer's

  void validate() const;  // RingError(bad_config) naming "frames.<key>"
};

// ioct-gpu's side. Not thread-safe: one thread publishes (the live stages' thread); heartbeat()
// and set_status() may come from another thread only if the caller serialises them with publish().
class FrameRingWriter {
 public:
  // Creates the object; a dead writer's object under the name is replaced, a live writer's is
  // refused (RingError owned_by_live_producer), a foreign object is left alone (RingError foreign).
  explicit FrameRingWriter(const FrameRingConfig& config);
  FrameRingWriter(FrameRingWriter&&) noexcept;
  FrameRingWriter& operator=(FrameRingWriter&&) noexcept;
  ~FrameRingWriter();  // close()

  // Publishes one frame: `meta` (frame_index and t_written_ns are set here; render_bytes,
  // bscan_bytes and tip_bscans_bytes from the spans) and its payload. Returns the frame index.
  // Throws std::length_error when the payload does not fit max_payload_bytes (nothing is
  // published).
  std::uint64_t publish(FrameMeta meta, std::span<const std::byte> render,
                        std::span<const std::byte> bscan,
                        std::span<const std::byte> tip_bscans = {});
  void heartbeat(std::uint64_t now_ns) noexcept;
  void set_status(const FrameRingStatus& status) noexcept;
  // Marks the ring closed and removes the name (readers keep their mapping and see closed).
  void close() noexcept;

  const std::string& name() const noexcept;
  std::uint64_t epoch() const noexcept;

 private:
  std::optional<ShmObject> object_;
  std::uint64_t next_frame_ = 0;
};

// A frame as a reader copied it.
struct Frame {
  FrameMeta meta{};
  std::vector<std::byte> payload;  // render bytes, then B-scan bytes
  std::span<const std::byte> render() const { return {payload.data(), meta.render_bytes}; }
  std::span<const std::byte> bscan() const {
    return {payload.data() + meta.render_bytes, meta.bscan_bytes};
  }
  std::span<const std::byte> tip_bscans() const {
    return {payload.data() + meta.render_bytes + meta.bscan_bytes, meta.tip_bscans_bytes};
  }
};

// What a reader sees of the writer.
struct FrameWriterHealth {
  bool alive = false;  // the writer's process is running and the ring not closed
  std::uint64_t heartbeat_age_ns = 0;
  std::uint64_t epoch = 0;
  std::uint64_t published = 0;
};

// ioct-view's side. Maps the object read-only; validates the header before touching a slot.
class FrameRingReader {
 public:
  // Throws RingError: not_found / not_ready (retry later), foreign, wrong_version, corrupt,
  // too_small, permission.
  static FrameRingReader attach(const std::string& name);

  FrameRingReader(FrameRingReader&&) noexcept;
  FrameRingReader& operator=(FrameRingReader&&) noexcept;
  ~FrameRingReader();

  // Copies the next frame not yet read into `out` (reusing its buffer); false when there is none.
  // Frames the writer overwrote before or during the copy are skipped and counted; a reader more
  // than a ring behind jumps to the oldest frame still there. A new writer epoch starts over.
  bool read_next(Frame& out);
  // Sleeps until a frame not yet read may be there or the writer closed the ring, at most
  // `timeout_ns` (the writer wakes its readers; a writer that died wakes nobody). Returns at once
  // when one is there already. True when there may be a frame to read.
  bool wait_for_frame(std::uint64_t timeout_ns) const;
  FrameWriterHealth health() const;
  // The pipeline status; false if the writer kept rewriting it during the copy (try again).
  bool read_status(FrameRingStatus& out) const;

  std::uint64_t frames_skipped() const noexcept { return skipped_; }
  const std::string& name() const noexcept;

 private:
  explicit FrameRingReader(ShmObject object);
  std::optional<ShmObject> object_;
  std::uint64_t epoch_ = 0;
  std::uint64_t next_ = 0;
  std::uint64_t skipped_ = 0;
};

// Throws RingError(corrupt | wrong_version | foreign | too_small) naming the field, for a header
// of an object of `object_bytes` bytes (also used by the fuzz target on raw bytes).
void validate_frame_ring_header(const FrameRingHeader& header, std::uint64_t object_bytes,
                                const std::string& name);

}  // namespace ioct::shm
