#include "strict_json.hpp"

#include <set>
#include <vector>

namespace ioct::view {

nlohmann::json parse_strict_json(std::string_view text, std::size_t max_bytes) {
  if (text.size() > max_bytes) {
    throw BadMessage("message of " + std::to_string(text.size()) + " bytes is larger than " +
                     std::to_string(max_bytes));
  }
  std::vector<std::set<std::string>> keys;  // one set per open object
  std::string duplicate;
  std::size_t depth_exceeded = 0;
  const auto check = [&](int depth, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
    using E = nlohmann::json::parse_event_t;
    if (static_cast<std::size_t>(depth) > kMaxJsonDepth) depth_exceeded = depth;
    if (event == E::object_start) keys.emplace_back();
    if (event == E::object_end && !keys.empty()) keys.pop_back();
    if (event == E::key && !keys.empty() && duplicate.empty()) {
      const std::string key = parsed.get<std::string>();
      if (!keys.back().insert(key).second) duplicate = key;
    }
    return true;
  };
  nlohmann::json value;
  try {
    value = nlohmann::json::parse(text.begin(), text.end(), check);
  } catch (const nlohmann::json::parse_error& e) {
    throw BadMessage("not valid JSON at byte " + std::to_string(e.byte));
  }
  if (depth_exceeded > 0) {
    throw BadMessage("nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
  }
  if (!duplicate.empty()) {
    throw BadMessage("the key " + quote_input(duplicate) + " appears twice", duplicate);
  }
  return value;
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
