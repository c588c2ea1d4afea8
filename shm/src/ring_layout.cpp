#include "ioct/shm/ring_layout.hpp"

#include <cinttypes>
#include <cstdio>
#include <string>

#include "ioct/shm/atomic_word.hpp"
#include "ioct/shm/ring_error.hpp"

namespace ioct::shm {
namespace {

// Largest ring we agree to create or map: far above any real geometry, far below what
// would overflow off_t or size_t arithmetic anywhere downstream.
constexpr std::uint64_t kMaxRingBytes = std::uint64_t{1} << 40;
constexpr std::uint64_t kMaxSlots = std::uint64_t{1} << 20;

[[noreturn]] void bad(const std::string& what) {
  throw RingError(RingErrc::bad_config, what);
}

bool round_up_to_page(std::uint64_t bytes, std::uint64_t& out) {
  if (bytes > UINT64_MAX - (kPageBytes - 1)) return false;
  out = (bytes + kPageBytes - 1) / kPageBytes * kPageBytes;
  return true;
}

std::string hex(std::uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%016" PRIx64, v);
  return buf;
}

}  // namespace

RingLayout RingLayout::compute(const RingGeometry& geometry, std::uint64_t slot_count,
                               std::uint64_t payload_capacity) {
  geometry.validate();
  if (slot_count < 2 || slot_count > kMaxSlots) {
    bad("ring: slot_count = " + std::to_string(slot_count) + " is out of range [2, " +
        std::to_string(kMaxSlots) + "] (one slot is always being written)");
  }
  RingLayout layout;
  layout.slot_count = slot_count;
  layout.group_payload_bytes = geometry.group_payload_bytes();
  const std::uint64_t wanted =
      payload_capacity == 0 ? layout.group_payload_bytes : payload_capacity;
  if (!round_up_to_page(wanted, layout.slot_payload_capacity)) {
    bad("ring: slot_payload_capacity = " + std::to_string(wanted) + " overflows when page-aligned");
  }
  if (layout.group_payload_bytes > layout.slot_payload_capacity) {
    bad("ring: a group's payload of " + std::to_string(layout.group_payload_bytes) +
        " bytes is larger than slot_payload_capacity = " + std::to_string(payload_capacity));
  }
  layout.slot_payload_offset = kPageBytes;  // SlotControl + SlotHeader fit in one page
  layout.first_slot_offset = kPageBytes;    // RingHeader fits in one page
  if (__builtin_add_overflow(layout.slot_payload_offset, layout.slot_payload_capacity,
                             &layout.slot_stride) ||
      __builtin_mul_overflow(layout.slot_stride, slot_count, &layout.total_bytes) ||
      __builtin_add_overflow(layout.total_bytes, layout.first_slot_offset, &layout.total_bytes)) {
    bad("ring: slot_count = " + std::to_string(slot_count) + " slots of " +
        std::to_string(layout.slot_payload_capacity) + " bytes overflow 64 bits");
  }
  if (layout.total_bytes > kMaxRingBytes) {
    bad("ring: slot_count = " + std::to_string(slot_count) + " slots of " +
        std::to_string(layout.slot_payload_capacity) + " bytes make " +
        std::to_string(layout.total_bytes) + " bytes, above the limit of " +
        std::to_string(kMaxRingBytes));
  }
  return layout;
}

RingLayout validate_header(const RingHeader& h, std::uint64_t object_bytes,
                           const char* object_name) {
  const std::string where = std::string("ring '") + object_name + "': ";
  if (object_bytes < sizeof(RingHeader)) {
    throw RingError(RingErrc::too_small, where + "object is " + std::to_string(object_bytes) +
                                             " bytes, smaller than the " +
                                             std::to_string(sizeof(RingHeader)) +
                                             "-byte ring header (truncated or not a ring)");
  }
  const std::uint64_t magic = load_word(h.magic, std::memory_order_acquire);
  if (magic == 0) {
    throw RingError(RingErrc::not_ready, where + "the producer has not finished initialising it");
  }
  if (magic != kRingMagic) {
    throw RingError(RingErrc::foreign, where + "magic is " + hex(magic) + ", expected " +
                                           hex(kRingMagic) + ": not an ioct ring");
  }
  if (h.layout_version != kRingLayoutVersion) {
    throw RingError(RingErrc::wrong_version,
                    where + "layout version " + std::to_string(h.layout_version) +
                        ", this build reads version " + std::to_string(kRingLayoutVersion));
  }
  const auto state = static_cast<RingState>(load_word(h.state, std::memory_order_acquire));
  if (state == RingState::closed || state == RingState::retired) {
    throw RingError(
        RingErrc::producer_gone,
        where + "the producer has " + (state == RingState::closed ? "closed" : "retired") + " it");
  }
  if (state == RingState::initializing) {
    throw RingError(RingErrc::not_ready, where + "the producer is (re)initialising it");
  }
  if (state != RingState::live) {
    throw RingError(RingErrc::corrupt,
                    where + "state = " + std::to_string(static_cast<std::uint64_t>(state)) +
                        " is not a ring state (0 initializing, 1 live, 2 closed, 3 retired)");
  }
  if (h.header_bytes != sizeof(RingHeader) || h.slot_header_bytes != sizeof(SlotHeader)) {
    throw RingError(RingErrc::corrupt,
                    where + "header_bytes = " + std::to_string(h.header_bytes) +
                        ", slot_header_bytes = " + std::to_string(h.slot_header_bytes) +
                        ", expected " + std::to_string(sizeof(RingHeader)) + " and " +
                        std::to_string(sizeof(SlotHeader)));
  }
  RingLayout layout;
  try {
    layout = RingLayout::compute(h.geometry, h.slot_count, h.slot_payload_capacity);
  } catch (const RingError& e) {
    throw RingError(RingErrc::corrupt, where + "header geometry is invalid: " + e.what());
  }
  auto expect = [&](const char* field, std::uint64_t stored, std::uint64_t derived) {
    if (stored != derived) {
      throw RingError(RingErrc::corrupt, where + field + " = " + std::to_string(stored) +
                                             " contradicts the geometry, which gives " +
                                             std::to_string(derived));
    }
  };
  expect("slot_stride", h.slot_stride, layout.slot_stride);
  expect("slot_payload_offset", h.slot_payload_offset, layout.slot_payload_offset);
  expect("group_payload_bytes", h.group_payload_bytes, layout.group_payload_bytes);
  expect("first_slot_offset", h.first_slot_offset, layout.first_slot_offset);
  expect("total_bytes", h.total_bytes, layout.total_bytes);
  if (object_bytes < layout.total_bytes) {
    throw RingError(RingErrc::too_small, where + "header needs " +
                                             std::to_string(layout.total_bytes) +
                                             " bytes but the object has only " +
                                             std::to_string(object_bytes) + " (truncated)");
  }
  return layout;
}

}  // namespace ioct::shm
