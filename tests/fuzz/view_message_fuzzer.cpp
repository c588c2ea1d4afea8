// ioct-view's browser messages (view/src/strict_json): every WebSocket message and HTTP API body
// is parsed by parse_strict_json before anything looks at it. Refused: too long, too deep,
// malformed, a duplicate key; each with a message that quotes the input safely.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "refusal.hpp"
#include "strict_json.hpp"

namespace {

// ioct-view's default view.max_message_bytes (view_config.hpp).
constexpr std::size_t kMaxMessageBytes = 64 * 1024;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const nlohmann::json message = ioct::view::parse_strict_json(text, kMaxMessageBytes);
    // What the WebSocket session reads next: an object's "type" and "id".
    if (message.is_object() && message.contains("type") && message["type"].is_string()) {
      (void)message["type"].get<std::string>();
    }
    (void)message.dump();
  } catch (const ioct::view::BadMessage& e) {
    ioct::fuzz::check_message(e.what());
  }
  return 0;
}
