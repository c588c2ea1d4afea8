// JSON from outside (control lines, view requests, browser messages), parsed so that a key given
// twice in one object is seen: with the usual "last one wins" a line such as
// {"cmd":"stop","cmd":"start"} would mean whatever the parser kept. Callers word their own refusal.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace ioct {

struct StrictJson {
  nlohmann::json value;        // discarded when the text is not JSON
  std::string error;           // the parser's message, printable (quote_input); empty if JSON
  std::size_t error_byte = 0;  // where the parser stopped
  std::string duplicate_key;   // the first key found twice in one object; empty: none
  std::size_t max_depth = 0;   // the deepest nesting met
};

// Never throws: text that is not JSON (or holds a number no double can take) gives a discarded
// value and the reason.
StrictJson parse_json_strictly(std::string_view text);

// A JSON value from outside as an error message may show it: every byte outside printable ASCII
// escaped (JSON's own escaping leaves DEL and non-ASCII bytes as they are), at most `max_chars`
// of it followed by "..." and how long it was.
std::string shown_json(const nlohmann::json& value, std::size_t max_chars = 60);

}  // namespace ioct
