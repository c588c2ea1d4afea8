// The frame ring's header check (shm validate_frame_ring_header), which FrameRingReader runs on
// the mapped object before it reads a frame: the input is the header's bytes, then 8 bytes of
// the object's size (the rest of a short input is zero).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "ioct/shm/frame_ring.hpp"
#include "ioct/shm/ring_error.hpp"
#include "refusal.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  ioct::shm::FrameRingHeader header{};
  std::memcpy(&header, data, std::min(size, sizeof header));
  std::uint64_t object_bytes = 0;
  if (size > sizeof header) {
    std::memcpy(&object_bytes, data + sizeof header,
                std::min(size - sizeof header, sizeof(std::uint64_t)));
  }
  try {
    ioct::shm::validate_frame_ring_header(header, object_bytes, "fuzz-frames");
    if (header.header_bytes + std::uint64_t{header.slot_count} * header.slot_stride >
        object_bytes) {
      ioct::fuzz::finding("accepted a frame ring header that does not fit the object", "");
    }
  } catch (const ioct::shm::RingError& e) {
    ioct::fuzz::check_message(e.what(), "fuzz-frames");
  }
  return 0;
}
