#include "ioct/common/error.hpp"

#include "ioct/common/command_main.hpp"
#include "ioct/common/log.hpp"

namespace ioct {

std::string_view to_string(ErrorCategory category) noexcept {
  switch (category) {
    case ErrorCategory::config:
      return "config";
    case ErrorCategory::environment:
      return "environment";
    case ErrorCategory::device:
      return "device";
    case ErrorCategory::data:
      return "data";
    case ErrorCategory::internal:
      return "internal";
  }
  return "internal";
}

int exit_status(ErrorCategory category) noexcept {
  return category == ErrorCategory::config ? kExitRefused : kExitFailed;
}

ErrorCategory category_of(const std::exception& e) noexcept {
  const auto* error = dynamic_cast<const Error*>(&e);
  return error != nullptr ? error->category() : ErrorCategory::internal;
}

std::string describe_failure(std::string_view program, const std::exception& e,
                             const FlagForKey& flag_for) {
  std::string line(program);
  switch (category_of(e)) {
    case ErrorCategory::config:
      line += ": invalid configuration: ";
      break;
    case ErrorCategory::data:
      line += ": bad input: ";
      break;
    case ErrorCategory::device:
      line += ": device error: ";
      break;
    case ErrorCategory::environment:
    case ErrorCategory::internal:
      line += ": error: ";
      break;
  }
  line += e.what();
  const auto* error = dynamic_cast<const Error*>(&e);
  if (flag_for && error != nullptr && !error->key().empty()) {
    const std::string flag = flag_for(error->key());
    if (!flag.empty()) line += " (option " + flag + ")";
  }
  return line;
}

int run_command(std::string_view program, const std::function<int()>& body,
                const FlagForKey& flag_for) {
  try {
    return body();
  } catch (const std::exception& e) {
    Log(std::string(program)).emit(Severity::error, describe_failure(program, e, flag_for));
    return exit_status(category_of(e));
  }
}

}  // namespace ioct
