// The group ring's header check (shm validate_header), which RingReader::attach runs on the
// mapped object before it touches a slot: the input is the header's bytes, then 8 bytes of the
// object's size (the rest of a short input is zero). A header it accepts must describe a ring
// that fits the object.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "refusal.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  ioct::shm::RingHeader header{};
  std::memcpy(&header, data, std::min(size, sizeof header));
  std::uint64_t object_bytes = 0;
  if (size > sizeof header) {
    std::memcpy(&object_bytes, data + sizeof header,
                std::min(size - sizeof header, sizeof(std::uint64_t)));
  }
  try {
    const ioct::shm::RingLayout layout =
        ioct::shm::validate_header(header, object_bytes, "fuzz-ring");
    if (layout.total_bytes > object_bytes || layout.slot_count == 0 ||
        layout.first_slot_offset + layout.slot_count * layout.slot_stride > layout.total_bytes) {
      ioct::fuzz::finding("accepted a header whose slots do not fit the object", "");
    }
  } catch (const ioct::shm::RingError& e) {
    ioct::fuzz::check_message(e.what(), "fuzz-ring");
  }
  return 0;
}
