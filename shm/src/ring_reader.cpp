#include "ioct/shm/ring_reader.hpp"

#include <atomic>
#include <cstring>
#include <stdexcept>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/shm/atomic_word.hpp"
#include "ioct/shm/ring_error.hpp"

#if defined(__SANITIZE_THREAD__)
extern "C" void AnnotateIgnoreReadsBegin(const char* file, int line);
extern "C" void AnnotateIgnoreReadsEnd(const char* file, int line);
#endif

// ThreadSanitizer does not model standalone fences (GCC says so with -Wtsan). The seqlock's
// fences order the racing payload copies, which TSan is told to ignore (seqlock_copy); every
// synchronisation TSan has to see goes through the acquire/release sequence words.
#if defined(__SANITIZE_THREAD__)
#pragma GCC diagnostic ignored "-Wtsan"
#endif

namespace ioct::shm {

void seqlock_copy(void* dst, const void* src, std::size_t bytes) noexcept {
#if defined(__SANITIZE_THREAD__)
  // The race with the writer is the seqlock's design: the sequence re-check rejects torn copies.
  AnnotateIgnoreReadsBegin(__FILE__, __LINE__);
  std::memcpy(dst, src, bytes);
  AnnotateIgnoreReadsEnd(__FILE__, __LINE__);
#else
  std::memcpy(dst, src, bytes);
#endif
}

namespace {

const std::uint64_t& sequence_of(const std::byte* slot) {
  return reinterpret_cast<const SlotControl*>(slot)->sequence;
}

}  // namespace

RingReader RingReader::attach(const std::string& name, const ReaderOptions& options) {
  ShmObject object = ShmObject::open(name, Access::read_only);
  const RingLayout layout = validate_header(*reinterpret_cast<const RingHeader*>(object.data()),
                                            object.size(), name.c_str());
  std::optional<ReaderStatusPublisher> status;
  if (options.publish_status) {
    status.emplace(name, options.label, options.status_mode, object.group_id());
  }
  return RingReader(std::move(object), layout, std::move(status));
}

RingReader::RingReader(ShmObject object, RingLayout layout,
                       std::optional<ReaderStatusPublisher> status)
    : object_(std::move(object)), layout_(layout), status_(std::move(status)) {
  const RingHeader& h = header();
  geometry_ = h.geometry;
  // Start at the newest group so a late reader shows something at once.
  const std::uint64_t published = load_word(h.published, std::memory_order_acquire);
  epoch_ = load_word(h.producer_epoch, std::memory_order_acquire);
  next_group_ = published > 0 ? published - 1 : 0;
  report();
}

const RingHeader& RingReader::header() const noexcept {
  return *reinterpret_cast<const RingHeader*>(object_.data());
}

std::uint64_t RingReader::producer_pid() const noexcept {
  // Relaxed: a producer taking the ring over rewrites it while we may read it.
  return load_word(header().producer_pid, std::memory_order_relaxed);
}

const std::byte* RingReader::slot(std::uint64_t index) const noexcept {
  return object_.data() + layout_.first_slot_offset + index * layout_.slot_stride;
}

std::optional<std::string> RingReader::status_object_name() const {
  if (!status_) return std::nullopt;
  return status_->object_name();
}

void RingReader::report() noexcept {
  if (status_) status_->update(monotonic_ns(), epoch_, next_group_, counters_);
}

void RingReader::heartbeat() noexcept {
  report();
}

PollStatus RingReader::begin_read(ReadTicket& ticket) noexcept {
  const RingHeader& h = header();
  const std::uint64_t slots = layout_.slot_count;
  // Each pass either returns or moves past a group; a writer that laps us every pass for a
  // whole ring's worth of groups is reported as a lap rather than chased forever.
  for (std::uint64_t pass = 0; pass < 2 * slots + 2; ++pass) {
    const auto state = static_cast<RingState>(load_word(h.state, std::memory_order_acquire));
    // A closed or retired ring is written no more: what it published is still read, to the
    // last group, so an orderly stop loses nothing. A value no producer writes: stop trusting
    // this mapping; attaching again finds the new producer or says what is wrong.
    const bool finished = state == RingState::closed || state == RingState::retired;
    if (!finished && state != RingState::live && state != RingState::initializing) {
      report();
      return PollStatus::producer_gone;
    }
    const std::uint64_t published = load_word(h.published, std::memory_order_acquire);
    // After the acquire above, so a reset cursor is never paired with the old epoch.
    const std::uint64_t epoch = load_word(h.producer_epoch, std::memory_order_acquire);
    if (epoch != epoch_) {
      // The producer restarted in place: its groups count from zero again.
      epoch_ = epoch;
      next_group_ = 0;
      ++counters_.epoch_changes;
      continue;
    }
    if (state == RingState::initializing || next_group_ >= published) {
      report();
      return finished ? PollStatus::producer_gone : PollStatus::empty;
    }
    // Group `published` is being written into the slot of group published - slots, so only the
    // newest slots - 1 groups are safe to start on.
    const std::uint64_t oldest = published >= slots ? published - slots + 1 : 0;
    if (next_group_ < oldest) {
      counters_.dropped_behind += published - 1 - next_group_;
      ++counters_.resyncs;
      next_group_ = published - 1;
    }
    const std::uint64_t index = next_group_ % slots;
    const std::byte* s = slot(index);
    if (load_word(sequence_of(s), std::memory_order_acquire) != published_sequence(next_group_)) {
      if (load_word(h.producer_epoch, std::memory_order_acquire) != epoch_) continue;
      ++counters_.dropped_lapped;  // overwritten between the cursor load and now
      ++next_group_;
      continue;
    }
    seqlock_copy(&ticket.header, s + sizeof(SlotControl), sizeof(SlotHeader));
    std::atomic_thread_fence(std::memory_order_acquire);
    if (load_word(sequence_of(s), std::memory_order_relaxed) != published_sequence(next_group_)) {
      ++counters_.dropped_lapped;
      ++next_group_;
      continue;
    }
    ticket.group = next_group_;
    ticket.epoch = epoch_;
    ticket.payload = s + layout_.slot_payload_offset;
    ticket.payload_bytes = layout_.group_payload_bytes;
    ticket.slot_index = index;
    return PollStatus::ready;
  }
  report();
  return PollStatus::lapped;
}

bool RingReader::end_read(const ReadTicket& ticket) noexcept {
  // Everything copied since begin_read() happens-before this point; if the writer touched the
  // slot meanwhile, its odd (or newer) sequence is visible now.
  std::atomic_thread_fence(std::memory_order_acquire);
  const RingHeader& h = header();
  const bool intact = load_word(sequence_of(slot(ticket.slot_index)), std::memory_order_acquire) ==
                          published_sequence(ticket.group) &&
                      load_word(h.producer_epoch, std::memory_order_acquire) == ticket.epoch;
  if (intact) {
    ++counters_.consumed;
  } else {
    ++counters_.dropped_lapped;
  }
  if (ticket.epoch == epoch_ && ticket.group >= next_group_) next_group_ = ticket.group + 1;
  report();
  return intact;
}

PollStatus RingReader::read_next(std::span<std::byte> payload, SlotHeader& header_out) {
  if (payload.size() < layout_.group_payload_bytes) {
    throw std::invalid_argument("RingReader::read_next: buffer of " +
                                std::to_string(payload.size()) + " bytes, a group needs " +
                                std::to_string(layout_.group_payload_bytes));
  }
  ReadTicket ticket;
  const PollStatus status = begin_read(ticket);
  if (status != PollStatus::ready) return status;
  seqlock_copy(payload.data(), ticket.payload, ticket.payload_bytes);
  if (!end_read(ticket)) return PollStatus::lapped;
  header_out = ticket.header;
  return PollStatus::ready;
}

}  // namespace ioct::shm
