// A frame as it goes to the browsers: one binary WebSocket message, made once and shared by every
// viewer of its view (docs/live-view.md): u32 little-endian length of a JSON description, the
// JSON, the render's JPEG, the B-scan's JPEG.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "ioct/shm/frame_ring.hpp"

namespace ioct::view {

struct FrameMessage {
  std::shared_ptr<const std::string> bytes;
  std::uint64_t frame_index = 0;
  std::uint64_t view_id = 0;
  std::uint64_t group_index = 0;
  std::uint64_t t_group_published_ns = 0;
};

FrameMessage make_frame_message(const shm::Frame& frame, std::uint64_t now_ns);

}  // namespace ioct::view
