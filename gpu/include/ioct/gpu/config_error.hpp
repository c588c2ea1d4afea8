// The error every config struct of gpu/ throws from validate(): it names the key, the value and
// the range, so a message reaches the person who typed the value with all they need to fix it.
#pragma once

#include <stdexcept>
#include <string>

namespace ioct::gpu {

class ConfigError : public std::invalid_argument {
 public:
  // what(): "<key> = <value>: <requirement>", e.g. "db_max = 3: must be greater than db_min (10)".
  ConfigError(std::string key, const std::string& value, const std::string& requirement)
      : std::invalid_argument(key + " = " + value + ": " + requirement), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

// Shortest decimal text that reads back as the same double ("2.5", "-300", "1e+30").
std::string format_number(double value);

// Throws ConfigError unless lo <= value <= hi (and value is a number).
void require_in_range(const std::string& key, double value, double lo, double hi);

}  // namespace ioct::gpu
