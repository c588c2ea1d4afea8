#include "ioct/shm/ring_writer.hpp"

#include <time.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <optional>
#include <utility>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/shm/atomic_word.hpp"
#include "ioct/shm/ring_error.hpp"

// ThreadSanitizer does not model standalone fences (GCC says so with -Wtsan). The seqlock's
// fences order the racing payload copies, which TSan is told to ignore (seqlock_copy); every
// synchronisation TSan has to see goes through the acquire/release sequence words.
#if defined(__SANITIZE_THREAD__)
#pragma GCC diagnostic ignored "-Wtsan"
#endif

namespace ioct::shm {
namespace {

bool same_layout(const RingHeader& h, const RingConfig& config, const RingLayout& layout,
                 std::uint64_t object_bytes) {
  return h.layout_version == kRingLayoutVersion && h.header_bytes == sizeof(RingHeader) &&
         h.slot_header_bytes == sizeof(SlotHeader) && h.geometry == config.geometry &&
         h.slot_count == layout.slot_count &&
         h.slot_payload_capacity == layout.slot_payload_capacity &&
         h.total_bytes == layout.total_bytes && object_bytes == layout.total_bytes;
}

// The stale-object policy. A ring object already under our name is
//  - refused when a live producer owns it, or when it is not a ring at all (we never delete
//    what we did not make);
//  - reinitialised in place when its producer is dead and its layout is ours, so readers that
//    still map it see a new epoch and resync without reattaching;
//  - otherwise marked retired (readers reattach) and unlinked, and a new object is created.
std::optional<ShmObject> take_over_stale(const RingConfig& config, const RingLayout& layout,
                                         StartupAction& action) {
  std::optional<ShmObject> old;
  try {
    old.emplace(ShmObject::open(config.name, Access::read_write));
  } catch (const RingError& e) {
    if (e.code() == RingErrc::not_found) return std::nullopt;
    if (e.code() != RingErrc::not_ready) throw;
    // Zero bytes: a producer died between creating and sizing it. Debris of ours.
    ShmObject::remove(config.name);
    action = StartupAction::replaced_stale;
    return std::nullopt;
  }
  auto& h = *reinterpret_cast<RingHeader*>(old->data());
  const bool has_header = old->size() >= sizeof(RingHeader);
  const std::uint64_t magic = has_header ? load_word(h.magic, std::memory_order_acquire) : 0;
  if (has_header && magic != 0 && magic != kRingMagic) {
    throw RingError(RingErrc::foreign,
                    "ring '" + config.name +
                        "': a shared-memory object of that name exists and is not an ioct ring; "
                        "not touching it (remove " +
                        object_path(config.name) + " if it is debris)");
  }
  if (magic == kRingMagic) {
    const ProcessIdentity owner{h.producer_pid, h.producer_start_ticks};
    const auto state = static_cast<RingState>(load_word(h.state, std::memory_order_acquire));
    if ((state == RingState::live || state == RingState::initializing) && owner.alive()) {
      throw RingError(RingErrc::owned_by_live_producer,
                      "ring '" + config.name + "' is in use by the running producer pid " +
                          std::to_string(owner.pid) + "; stop it first");
    }
    if (same_layout(h, config, layout, old->size())) {
      action = StartupAction::reused_stale;
      return old;
    }
    store_word(h.state, static_cast<std::uint64_t>(RingState::retired), std::memory_order_release);
  }
  ShmObject::remove(config.name);
  action = StartupAction::replaced_stale;
  return std::nullopt;
}

}  // namespace

void RingConfig::validate() const {
  if (const std::string problem = object_name_problem(name); !problem.empty()) {
    throw RingError(RingErrc::bad_config, "ring: name = '" + name + "' " + problem);
  }
  if ((mode & ~0777u) != 0 || (mode & 0600u) != 0600u || (mode & 0022u) != 0) {
    char octal[16];
    std::snprintf(octal, sizeof octal, "0%o", mode);
    throw RingError(RingErrc::bad_config,
                    std::string("ring: mode = ") + octal +
                        " must let the owner read and write and nobody else write (readers "
                        "only read; whoever may write may truncate): e.g. 0640");
  }
  (void)RingLayout::compute(geometry, slot_count, slot_payload_capacity);
}

RingWriter RingWriter::create(const RingConfig& config) {
  config.validate();
  const RingLayout layout =
      RingLayout::compute(config.geometry, config.slot_count, config.slot_payload_capacity);
  StartupAction action = StartupAction::created;
  std::optional<ShmObject> object = take_over_stale(config, layout, action);
  const bool in_place = object.has_value();
  if (in_place) {
    object->set_access(config.mode, config.group);
  } else {
    object.emplace(ShmObject::create(config.name, layout.total_bytes, config.mode, config.group));
  }
  RingWriter writer(config, layout, std::move(*object), action);
  writer.initialize(in_place);
  return writer;
}

RingWriter::RingWriter(RingConfig config, RingLayout layout, ShmObject object, StartupAction action)
    : config_(std::move(config)),
      layout_(layout),
      object_(std::move(object)),
      startup_action_(action) {}

RingWriter::RingWriter(RingWriter&& other) noexcept
    : config_(std::move(other.config_)),
      layout_(other.layout_),
      object_(std::move(other.object_)),
      startup_action_(other.startup_action_),
      memory_locked_(other.memory_locked_),
      open_(std::exchange(other.open_, false)),
      epoch_(other.epoch_),
      next_group_(other.next_group_) {}

RingWriter::~RingWriter() {
  close();
}

void RingWriter::initialize(bool in_place) {
  RingHeader& h = header();
  const std::uint64_t old_epoch =
      in_place ? load_word(h.producer_epoch, std::memory_order_relaxed) : 0;
  if (in_place) {
    store_word(h.state, static_cast<std::uint64_t>(RingState::initializing),
               std::memory_order_release);
  }

  memory_locked_ = object_.prefault_and_lock();
  if (!memory_locked_ && config_.memory_lock == MemoryLock::required) {
    ShmObject::remove(config_.name);
    open_ = false;
    throw RingError(RingErrc::system, "ring '" + config_.name + "': mlock of " +
                                          std::to_string(layout_.total_bytes) +
                                          " bytes refused; raise RLIMIT_MEMLOCK (LimitMEMLOCK=)");
  }

  const ProcessIdentity self = ProcessIdentity::self();
  h.layout_version = kRingLayoutVersion;
  h.header_bytes = sizeof(RingHeader);
  h.slot_header_bytes = sizeof(SlotHeader);
  h.geometry = config_.geometry;
  h.slot_count = layout_.slot_count;
  h.slot_stride = layout_.slot_stride;
  h.slot_payload_offset = layout_.slot_payload_offset;
  h.slot_payload_capacity = layout_.slot_payload_capacity;
  h.group_payload_bytes = layout_.group_payload_bytes;
  h.first_slot_offset = layout_.first_slot_offset;
  h.total_bytes = layout_.total_bytes;
  h.producer_pid = self.pid;
  h.producer_start_ticks = self.start_ticks;
  h.created_realtime_ns = clock_ns(CLOCK_REALTIME);

  // The epoch goes first: a reader that sees any reset word below (acquire) also sees it.
  epoch_ = std::max(old_epoch + 1, clock_ns(CLOCK_REALTIME));
  store_word(h.producer_epoch, epoch_, std::memory_order_relaxed);
  store_word(h.published, 0, std::memory_order_release);
  for (std::uint64_t i = 0; i < layout_.slot_count; ++i) {
    store_word(reinterpret_cast<SlotControl*>(slot(i))->sequence, 0, std::memory_order_release);
  }
  next_group_ = 0;
  store_word(h.state, static_cast<std::uint64_t>(RingState::live), std::memory_order_release);
  store_word(h.magic, kRingMagic, std::memory_order_release);
}

RingHeader& RingWriter::header() const noexcept {
  return *reinterpret_cast<RingHeader*>(object_.data());
}

std::byte* RingWriter::slot(std::uint64_t index) const noexcept {
  return object_.data() + layout_.first_slot_offset + index * layout_.slot_stride;
}

RingWriter::Claim RingWriter::claim() noexcept {
  const std::uint64_t group = next_group_;
  std::byte* s = slot(group % layout_.slot_count);
  store_word(reinterpret_cast<SlotControl*>(s)->sequence, writing_sequence(group),
             std::memory_order_relaxed);
  // The odd sequence must be visible before any byte of the new group: a reader whose copy
  // saw a new byte then sees a changed sequence when it re-checks.
  std::atomic_thread_fence(std::memory_order_release);
  return Claim{group, reinterpret_cast<SlotHeader*>(s + sizeof(SlotControl)),
               std::span<std::byte>(s + layout_.slot_payload_offset, layout_.group_payload_bytes)};
}

void RingWriter::publish(const Claim& claim) noexcept {
  SlotHeader& h = *claim.header;
  h.group_index = claim.group;
  h.producer_epoch = epoch_;
  h.payload_bytes = layout_.group_payload_bytes;
  h.t_publish_ns = monotonic_ns();
  std::byte* s = slot(claim.group % layout_.slot_count);
  // Release: header and payload happen-before any reader that acquires the even sequence.
  store_word(reinterpret_cast<SlotControl*>(s)->sequence, published_sequence(claim.group),
             std::memory_order_release);
  next_group_ = claim.group + 1;
  store_word(header().published, next_group_, std::memory_order_release);
}

void RingWriter::close() noexcept {
  if (!open_) return;
  open_ = false;
  store_word(header().state, static_cast<std::uint64_t>(RingState::closed),
             std::memory_order_release);
  ShmObject::remove(config_.name);
}

std::vector<ReaderReport> RingWriter::readers() const {
  return scan_reader_status(config_.name);
}

std::size_t RingWriter::reap_dead_readers() const {
  std::size_t reaped = 0;
  for (const ReaderReport& r : readers()) {
    if (!r.alive && ShmObject::remove(r.object_name)) ++reaped;
  }
  return reaped;
}

}  // namespace ioct::shm
