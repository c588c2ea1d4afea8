// JSON from outside (browser messages, HTTP bodies), parsed strictly: a size limit, a depth
// limit, and a duplicated key is an error rather than "the last one wins" (a message such as
// {"cmd":"stop","cmd":"start"} must not mean whatever the parser happens to keep).
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <string_view>

namespace ioct::view {

class BadMessage : public std::invalid_argument {
 public:
  // what(): a person-readable reason; key(): the member at fault, when one is.
  BadMessage(std::string message, std::string key = {})
      : std::invalid_argument(std::move(message)), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

inline constexpr std::size_t kMaxJsonDepth = 16;

// Throws BadMessage: too long, too deep, malformed (with the byte offset), duplicate key.
nlohmann::json parse_strict_json(std::string_view text, std::size_t max_bytes);

// Input quoted for a message: printable ASCII only, at most `max_chars`, with "..." when cut.
std::string quote_input(std::string_view text, std::size_t max_chars = 40);

}  // namespace ioct::view
