// Base64 (RFC 4648) decoding, for the screenshots DevTools sends as text.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

namespace ioct::devtools {

// Throws std::invalid_argument on a character outside the alphabet.
std::vector<std::uint8_t> decode_base64(std::string_view text);

}  // namespace ioct::devtools
