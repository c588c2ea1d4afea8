#include "strict_json.hpp"

#include "ioct/common/strict_json.hpp"

namespace ioct::view {

nlohmann::json parse_strict_json(std::string_view text, std::size_t max_bytes) {
  if (text.size() > max_bytes) {
    throw BadMessage("message of " + std::to_string(text.size()) + " bytes is larger than " +
                     std::to_string(max_bytes));
  }
  const StrictJson parsed = parse_json_strictly(text);
  if (parsed.value.is_discarded()) {
    throw BadMessage("not valid JSON at byte " + std::to_string(parsed.error_byte));
  }
  if (parsed.max_depth > kMaxJsonDepth) {
    throw BadMessage("nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
  }
  if (!parsed.duplicate_key.empty()) {
    throw BadMessage("the key " + quote_input(parsed.duplicate_key) + " appears twice",
                     parsed.duplicate_key);
  }
  return parsed.value;
}

std::string quote_input(std::string_view text, std::size_t max_chars) {
  std::string out = "'";
  for (std::size_t i = 0; i < text.size() && i < max_chars; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    out.push_back(c >= 0x20 && c < 0x7f ? static_cast<char>(c) : '?');
  }
  if (text.size() > max_chars) out += "...";
  out += "'";
  return out;
}

}  // namespace ioct::view
