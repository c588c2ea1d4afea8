#include "ioct/shm/frame_ring.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <type_traits>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/shm/atomic_word.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "ioct/shm/ring_reader.hpp"  // seqlock_copy
#include "shared_futex.hpp"

// ThreadSanitizer does not model standalone fences; see ring_reader.cpp.
#if defined(__SANITIZE_THREAD__)
#pragma GCC diagnostic ignored "-Wtsan"
#endif

namespace ioct::shm {
namespace {

static_assert(std::is_trivially_copyable_v<FrameMeta>);
static_assert(std::is_trivially_copyable_v<FrameRingHeader>);
static_assert(std::is_trivially_copyable_v<FrameRingStatus>);
static_assert(sizeof(FrameRingHeader) <= kPageBytes);
static_assert(sizeof(FrameSlotHeader) <= kPageBytes);

constexpr std::uint64_t kSlotHeaderBytes = kPageBytes;  // the payload starts on a page boundary

std::uint64_t round_up_to_page(std::uint64_t bytes) {
  return (bytes + kPageBytes - 1) / kPageBytes * kPageBytes;
}

std::uint64_t slot_stride_for(std::uint64_t max_payload_bytes) {
  return kSlotHeaderBytes + round_up_to_page(max_payload_bytes);
}

FrameRingHeader& header_of(const ShmObject& object) {
  return *reinterpret_cast<FrameRingHeader*>(object.data());
}

std::byte* slot_of(const ShmObject& object, std::uint64_t frame) {
  const FrameRingHeader& h = header_of(object);
  return object.data() + h.header_bytes + (frame % h.slot_count) * h.slot_stride;
}

FrameSlotHeader& slot_header(std::byte* slot) {
  return *reinterpret_cast<FrameSlotHeader*>(slot);
}

// A frame ring already under the name: refused when its writer lives or when it is not a frame
// ring; otherwise (a dead writer's debris, or half made) marked closed and unlinked.
void clear_stale(const std::string& name) {
  std::optional<ShmObject> old;
  try {
    old.emplace(ShmObject::open(name, Access::read_write));
  } catch (const RingError& e) {
    if (e.code() == RingErrc::not_found) return;
    if (e.code() != RingErrc::not_ready) throw;
    ShmObject::remove(name);  // 0 bytes: a writer died between creating and sizing it
    return;
  }
  if (old->size() >= sizeof(FrameRingHeader)) {
    FrameRingHeader& h = header_of(*old);
    const std::uint64_t magic = load_word(h.magic, std::memory_order_acquire);
    if (magic != 0 && magic != kFrameRingMagic) {
      throw RingError(RingErrc::foreign, "frame ring '" + name +
                                             "': a shared-memory object of that name exists and "
                                             "is not an ioct frame ring; not touching it");
    }
    if (magic == kFrameRingMagic) {
      const ProcessIdentity owner{h.writer_pid, h.writer_start_ticks};
      if (load_word(h.closed, std::memory_order_acquire) == 0 && owner.alive()) {
        throw RingError(RingErrc::owned_by_live_producer,
                        "frame ring '" + name + "' is in use by the running writer pid " +
                            std::to_string(owner.pid) + "; stop it first");
      }
      store_word(h.closed, 1, std::memory_order_release);  // readers still mapping it reattach
    }
  }
  ShmObject::remove(name);
}

}  // namespace

void FrameRingConfig::validate() const {
  if (const std::string problem = object_name_problem(name); !problem.empty()) {
    throw RingError(RingErrc::bad_config, "frames.name = '" + name + "': " + problem);
  }
  if (slots < 2 || slots > kMaxFrameSlots) {
    throw RingError(RingErrc::bad_config, "frames.slots = " + std::to_string(slots) +
                                              ": must be in [2, " + std::to_string(kMaxFrameSlots) +
                                              "]");
  }
  if (max_payload_bytes < kPageBytes || max_payload_bytes > kMaxFramePayloadBytes) {
    throw RingError(RingErrc::bad_config,
                    "frames.max_payload_bytes = " + std::to_string(max_payload_bytes) +
                        ": must be in [" + std::to_string(kPageBytes) + ", " +
                        std::to_string(kMaxFramePayloadBytes) + "]");
  }
  if ((mode & ~0777u) != 0 || (mode & 0600u) != 0600u) {
    char octal[16];
    std::snprintf(octal, sizeof octal, "0%o", mode);
    throw RingError(RingErrc::bad_config,
                    std::string("frames.mode = ") + octal +
                        ": must be a file mode that lets the owner read and write");
  }
}

void validate_frame_ring_header(const FrameRingHeader& h, std::uint64_t object_bytes,
                                const std::string& name) {
  const std::string what = "frame ring '" + name + "': ";
  if (object_bytes < sizeof(FrameRingHeader)) {
    throw RingError(RingErrc::too_small, what + "the object has " + std::to_string(object_bytes) +
                                             " bytes, less than its header");
  }
  if (h.magic != kFrameRingMagic) throw RingError(RingErrc::foreign, what + "not a frame ring");
  if (h.layout_version != kFrameRingVersion) {
    throw RingError(RingErrc::wrong_version, what + "layout version " +
                                                 std::to_string(h.layout_version) + ", expected " +
                                                 std::to_string(kFrameRingVersion));
  }
  const auto corrupt = [&](const char* field, std::uint64_t value) {
    return RingError(RingErrc::corrupt,
                     what + field + " = " + std::to_string(value) + " does not fit the layout");
  };
  if (h.header_bytes != kPageBytes) throw corrupt("header_bytes", h.header_bytes);
  if (h.slot_count < 2 || h.slot_count > kMaxFrameSlots) throw corrupt("slot_count", h.slot_count);
  if (h.max_payload_bytes < kPageBytes || h.max_payload_bytes > kMaxFramePayloadBytes) {
    throw corrupt("max_payload_bytes", h.max_payload_bytes);
  }
  if (h.slot_stride != slot_stride_for(h.max_payload_bytes)) {
    throw corrupt("slot_stride", h.slot_stride);
  }
  // Both factors are bounded above, so the product cannot overflow.
  const std::uint64_t needed = h.header_bytes + std::uint64_t{h.slot_count} * h.slot_stride;
  if (object_bytes < needed) {
    throw RingError(RingErrc::too_small, what + "the object has " + std::to_string(object_bytes) +
                                             " bytes, its header needs " + std::to_string(needed));
  }
}

// ---- writer ----

FrameRingWriter::FrameRingWriter(const FrameRingConfig& config) {
  config.validate();
  clear_stale(config.name);
  const std::uint64_t stride = slot_stride_for(config.max_payload_bytes);
  const std::uint64_t bytes = kPageBytes + std::uint64_t{config.slots} * stride;
  object_.emplace(ShmObject::create(config.name, bytes, config.mode, config.group));
  object_->prefault_and_lock();  // frames are written from a render thread: no page faults there
  FrameRingHeader& h = header_of(*object_);
  const ProcessIdentity self = ProcessIdentity::self();
  h.layout_version = kFrameRingVersion;
  h.slot_count = config.slots;
  h.header_bytes = kPageBytes;
  h.slot_stride = stride;
  h.max_payload_bytes = config.max_payload_bytes;
  h.writer_pid = self.pid;
  h.writer_start_ticks = self.start_ticks;
  // A new object each start, and an epoch no earlier writer had: the clock at creation.
  store_word(h.epoch, monotonic_ns(), std::memory_order_relaxed);
  store_word(h.heartbeat_ns, monotonic_ns(), std::memory_order_relaxed);
  store_word(h.magic, kFrameRingMagic, std::memory_order_release);  // last: the object is ready
}

FrameRingWriter::FrameRingWriter(FrameRingWriter&& other) noexcept
    : object_(std::move(other.object_)), next_frame_(other.next_frame_) {
  other.object_.reset();
}

FrameRingWriter& FrameRingWriter::operator=(FrameRingWriter&& other) noexcept {
  if (this != &other) {
    close();
    object_ = std::move(other.object_);
    other.object_.reset();
    next_frame_ = other.next_frame_;
  }
  return *this;
}

FrameRingWriter::~FrameRingWriter() {
  close();
}

std::uint64_t FrameRingWriter::publish(FrameMeta meta, std::span<const std::byte> render,
                                       std::span<const std::byte> bscan,
                                       std::span<const std::byte> tip_bscans) {
  if (!object_) throw std::logic_error("frame ring: publish() after close()");
  FrameRingHeader& h = header_of(*object_);
  const std::uint64_t bytes = std::uint64_t{render.size()} + bscan.size() + tip_bscans.size();
  if (bytes > h.max_payload_bytes) {
    throw std::length_error("frame ring '" + object_->name() + "': a frame of " +
                            std::to_string(bytes) + " bytes does not fit its " +
                            std::to_string(h.max_payload_bytes) + "-byte slots");
  }
  const std::uint64_t f = next_frame_++;
  std::byte* slot = slot_of(*object_, f);
  FrameSlotHeader& s = slot_header(slot);
  store_word(s.sequence, 2 * f + 1, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);  // odd before any new byte

  const std::uint64_t now = monotonic_ns();
  meta.frame_index = f;
  meta.t_written_ns = now;
  meta.render_bytes = static_cast<std::uint32_t>(render.size());
  meta.bscan_bytes = static_cast<std::uint32_t>(bscan.size());
  meta.tip_bscans_bytes = static_cast<std::uint32_t>(tip_bscans.size());
  meta.mode[kFrameModeNameBytes - 1] = '\0';
  std::memcpy(&s.meta, &meta, sizeof meta);
  std::byte* payload = slot + kSlotHeaderBytes;
  if (!render.empty()) std::memcpy(payload, render.data(), render.size());
  if (!bscan.empty()) std::memcpy(payload + render.size(), bscan.data(), bscan.size());
  if (!tip_bscans.empty()) {
    std::memcpy(payload + render.size() + bscan.size(), tip_bscans.data(), tip_bscans.size());
  }

  store_word(s.sequence, 2 * f + 2, std::memory_order_release);
  store_word(h.published, f + 1, std::memory_order_release);
  store_word(h.heartbeat_ns, now, std::memory_order_release);
  shared_futex_bump_and_wake(h.frame_signal);
  return f;
}

void FrameRingWriter::heartbeat(std::uint64_t now_ns) noexcept {
  if (object_) store_word(header_of(*object_).heartbeat_ns, now_ns, std::memory_order_release);
}

void FrameRingWriter::set_status(const FrameRingStatus& status) noexcept {
  if (!object_) return;
  FrameRingHeader& h = header_of(*object_);
  const std::uint64_t seq = load_word(h.status_sequence, std::memory_order_relaxed);
  store_word(h.status_sequence, seq + 1, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  std::memcpy(&h.status, &status, sizeof status);
  store_word(h.status_sequence, seq + 2, std::memory_order_release);
}

void FrameRingWriter::close() noexcept {
  if (!object_) return;
  FrameRingHeader& h = header_of(*object_);
  store_word(h.closed, 1, std::memory_order_release);
  shared_futex_bump_and_wake(h.frame_signal);  // sleeping readers see "closed" now
  ShmObject::remove(object_->name());
  object_.reset();
}

const std::string& FrameRingWriter::name() const noexcept {
  static const std::string closed;
  return object_ ? object_->name() : closed;
}

std::uint64_t FrameRingWriter::epoch() const noexcept {
  return object_ ? load_word(header_of(*object_).epoch, std::memory_order_relaxed) : 0;
}

// ---- reader ----

FrameRingReader FrameRingReader::attach(const std::string& name) {
  ShmObject object = ShmObject::open(name, Access::read_only);
  if (object.size() < sizeof(FrameRingHeader)) {
    throw RingError(RingErrc::not_ready, "frame ring '" + name + "' is still being made");
  }
  const FrameRingHeader& live = header_of(object);
  if (load_word(live.magic, std::memory_order_acquire) == 0) {
    throw RingError(RingErrc::not_ready, "frame ring '" + name + "' is still being made");
  }
  FrameRingHeader copy;
  std::memcpy(&copy, &live, sizeof copy);
  validate_frame_ring_header(copy, object.size(), name);
  return FrameRingReader(std::move(object));
}

FrameRingReader::FrameRingReader(ShmObject object) : object_(std::move(object)) {
  epoch_ = load_word(header_of(*object_).epoch, std::memory_order_acquire);
}

FrameRingReader::FrameRingReader(FrameRingReader&& other) noexcept = default;
FrameRingReader& FrameRingReader::operator=(FrameRingReader&& other) noexcept = default;
FrameRingReader::~FrameRingReader() = default;

const std::string& FrameRingReader::name() const noexcept {
  return object_->name();
}

bool FrameRingReader::read_next(Frame& out) {
  const FrameRingHeader& h = header_of(*object_);
  const std::uint64_t published = load_word(h.published, std::memory_order_acquire);
  const std::uint64_t epoch = load_word(h.epoch, std::memory_order_acquire);
  if (epoch != epoch_) {
    epoch_ = epoch;
    next_ = 0;
  }
  while (next_ < published) {
    if (published - next_ > h.slot_count) {  // a ring behind: to the oldest frame still there
      skipped_ += published - h.slot_count - next_;
      next_ = published - h.slot_count;
    }
    const std::uint64_t f = next_++;
    std::byte* slot = slot_of(*object_, f);
    const FrameSlotHeader& s = slot_header(slot);
    const std::uint64_t expected = 2 * f + 2;
    if (load_word(s.sequence, std::memory_order_acquire) != expected) {
      ++skipped_;  // already overwritten by a later frame
      continue;
    }
    seqlock_copy(&out.meta, &s.meta, sizeof out.meta);
    const std::uint64_t bytes =
        std::uint64_t{out.meta.render_bytes} + out.meta.bscan_bytes + out.meta.tip_bscans_bytes;
    if (bytes <= h.max_payload_bytes) {
      out.payload.resize(bytes);
      seqlock_copy(out.payload.data(), slot + kSlotHeaderBytes, bytes);
    }
    std::atomic_thread_fence(std::memory_order_acquire);
    if (load_word(s.sequence, std::memory_order_relaxed) != expected ||
        bytes > h.max_payload_bytes) {
      ++skipped_;  // torn: the writer came round during the copy
      continue;
    }
    out.meta.mode[kFrameModeNameBytes - 1] = '\0';
    return true;
  }
  return false;
}

bool FrameRingReader::wait_for_frame(std::uint64_t timeout_ns) const {
  const FrameRingHeader& h = header_of(*object_);
  const auto frame_or_close = [&] {
    return load_word(h.published, std::memory_order_acquire) != next_ ||
           load_word(h.epoch, std::memory_order_acquire) != epoch_ ||
           load_word(h.closed, std::memory_order_acquire) != 0;
  };
  // The signal first: a frame published after this load changes it, so the wait returns at once.
  const std::uint32_t signal = load_word(h.frame_signal, std::memory_order_acquire);
  if (frame_or_close()) return true;
  shared_futex_wait(h.frame_signal, signal, timeout_ns);
  return frame_or_close();
}

FrameWriterHealth FrameRingReader::health() const {
  const FrameRingHeader& h = header_of(*object_);
  FrameWriterHealth health;
  const std::uint64_t beat = load_word(h.heartbeat_ns, std::memory_order_acquire);
  const std::uint64_t now = monotonic_ns();
  health.heartbeat_age_ns = now > beat ? now - beat : 0;
  health.epoch = load_word(h.epoch, std::memory_order_relaxed);
  health.published = load_word(h.published, std::memory_order_relaxed);
  health.alive = load_word(h.closed, std::memory_order_acquire) == 0 &&
                 ProcessIdentity{h.writer_pid, h.writer_start_ticks}.alive();
  return health;
}

bool FrameRingReader::read_status(FrameRingStatus& out) const {
  const FrameRingHeader& h = header_of(*object_);
  const std::uint64_t before = load_word(h.status_sequence, std::memory_order_acquire);
  if ((before & 1) != 0) return false;
  seqlock_copy(&out, &h.status, sizeof out);
  std::atomic_thread_fence(std::memory_order_acquire);
  return load_word(h.status_sequence, std::memory_order_relaxed) == before;
}

}  // namespace ioct::shm
