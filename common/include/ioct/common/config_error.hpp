// The error every component's Config::validate() throws: it names the key, the value given and
// what would have been accepted, so a person can fix the config without reading the code.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "ioct/common/error.hpp"

namespace ioct {

// Category config (error.hpp); key() is the key it names.
class ConfigError : public std::invalid_argument, public Error {
 public:
  // what(): "<key> = <value>: <allowed>", e.g. "digitizer.samples_per_ascan = 0: must be in
  // [64, 16384]".
  ConfigError(std::string key, std::string value, std::string_view allowed);

  const std::string& value() const noexcept { return value_; }

 private:
  std::string value_;
};

// Text of a number as the messages show it: integers exactly, reals in the shortest form that
// reads back to the same value.
std::string format_value(std::uint64_t value);
std::string format_value(std::int64_t value);
std::string format_value(double value);
// Text as the messages show it: in double quotes, printable and shortened (quote_input), since it
// came from outside.
std::string format_text(std::string_view text);

// Throw ConfigError unless lo <= value <= hi (and, for reals, value is finite).
void require_integer_in_range(std::string_view key, std::uint64_t value, std::uint64_t lo,
                              std::uint64_t hi);
void require_real_in_range(std::string_view key, double value, double lo, double hi);

}  // namespace ioct
