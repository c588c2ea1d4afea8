// The project's one error vocabulary: what kind of failure an error is (its category), the config
// key it concerns where there is one, and the one rule that turns a category into a command's exit
// status. Every error type of ours carries it as a second base beside its standard exception, so
// `catch (const std::exception&)` still has what() and category_of() the kind.
#pragma once

#include <exception>
#include <string>
#include <string_view>
#include <utility>

namespace ioct {

enum class ErrorCategory {
  config,       // the configuration or the command line: refused before anything was touched
  environment,  // what this machine or its other processes lack: a ring, a group, room, rights
  device,       // the hardware or the GPU failed
  data,         // an input file or a recording is damaged or not what it claims
  internal,     // anything else: a bug
};

std::string_view to_string(ErrorCategory category) noexcept;

// Every command's exit status: 0 done; 2 its configuration or command line was refused (nothing
// was touched); 1 it ran, or tried to, and failed.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;
inline constexpr int kExitRefused = 2;
int exit_status(ErrorCategory category) noexcept;

class Error {
 public:
  virtual ~Error() = default;
  ErrorCategory category() const noexcept { return category_; }
  // The configuration key the error concerns ("ring.slots"), or empty.
  const std::string& key() const noexcept { return key_; }

 protected:
  explicit Error(ErrorCategory category, std::string key = {})
      : category_(category), key_(std::move(key)) {}
  Error(const Error&) = default;
  Error& operator=(const Error&) = default;

 private:
  ErrorCategory category_;
  std::string key_;
};

// The category of `e`: its Error's, or internal for any other exception.
ErrorCategory category_of(const std::exception& e) noexcept;

}  // namespace ioct
