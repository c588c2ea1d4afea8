#include "ioct/common/strict_json.hpp"

#include "ioct/common/input_file.hpp"

#include <set>
#include <vector>

namespace ioct {
namespace {

constexpr std::size_t kMaxErrorChars = 240;

}  // namespace

std::string shown_json(const nlohmann::json& value, std::size_t max_chars) {
  std::string text = value.dump(-1, ' ', true, nlohmann::json::error_handler_t::replace);
  if (text.size() > max_chars) {
    text = text.substr(0, max_chars) + "... (" + std::to_string(text.size()) + " bytes)";
  }
  return text;
}

StrictJson parse_json_strictly(std::string_view text) {
  StrictJson result;
  std::vector<std::set<std::string>> keys;  // one set per open object
  const nlohmann::json::parser_callback_t note = [&](int depth, nlohmann::json::parse_event_t event,
                                                     nlohmann::json& parsed) {
    using Event = nlohmann::json::parse_event_t;
    if (depth > 0) result.max_depth = std::max(result.max_depth, static_cast<std::size_t>(depth));
    if (event == Event::object_start) {
      keys.emplace_back();
    } else if (event == Event::object_end && !keys.empty()) {
      keys.pop_back();
    } else if (event == Event::key && !keys.empty() && parsed.is_string()) {
      const auto& key = parsed.get_ref<const std::string&>();
      if (!keys.back().insert(key).second && result.duplicate_key.empty()) {
        result.duplicate_key = key;
      }
    }
    return true;
  };
  try {
    result.value = nlohmann::json::parse(text.begin(), text.end(), note);
  } catch (const nlohmann::json::parse_error& e) {
    result.value = nlohmann::json::value_t::discarded;
    // The parser's message shows the bytes it stopped at, DEL and non-ASCII ones raw.
    result.error = quote_input(e.what(), kMaxErrorChars);
    result.error_byte = e.byte;
  } catch (const nlohmann::json::exception& e) {  // e.g. a number too large for a double
    result.value = nlohmann::json::value_t::discarded;
    result.error = quote_input(e.what(), kMaxErrorChars);
    result.error_byte = text.size();
  }
  return result;
}

}  // namespace ioct
