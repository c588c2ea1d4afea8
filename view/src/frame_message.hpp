// A frame as it goes to the browsers: one binary WebSocket message, made once and shared by every
// viewer of its view (docs/live-view.md): u32 little-endian length of a JSON description, the
// JSON, the render's JPEG, the B-scan's JPEG, the tip's B-scan pair. And the same frame without
// the B-scan and the pair ("pictures_repeated"), for a viewer who was last sent those very bytes:
// ioct-gpu encodes them anew only after a pass that touched them, so most frames repeat them.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "ioct/shm/frame_ring.hpp"

namespace ioct::view {

struct FrameMessage {
  std::shared_ptr<const std::string> bytes;
  // The frame without its pictures (null when it has none to leave out), and which pictures it
  // carries: frames with the same number carry the same B-scan and pair, byte for byte.
  std::shared_ptr<const std::string> without_pictures;
  std::uint64_t pictures = 0;
  std::uint64_t frame_index = 0;
  std::uint64_t view_id = 0;
  std::uint64_t group_index = 0;
  std::uint64_t t_group_published_ns = 0;
};

// `pictures`: the number of the frame's B-scan and tip pair ("pictures" in the JSON);
// `pictures_new`: no frame made before had them, so no viewer can be sent the frame without them.
FrameMessage make_frame_message(const shm::Frame& frame, std::uint64_t now_ns,
                                std::uint64_t pictures, bool pictures_new);

}  // namespace ioct::view
