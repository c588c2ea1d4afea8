#include "ioct/shm/ring_error.hpp"

namespace ioct::shm {

std::string_view to_string(RingErrc code) noexcept {
  switch (code) {
    case RingErrc::bad_config:
      return "bad_config";
    case RingErrc::not_found:
      return "not_found";
    case RingErrc::permission:
      return "permission";
    case RingErrc::not_ready:
      return "not_ready";
    case RingErrc::producer_gone:
      return "producer_gone";
    case RingErrc::too_small:
      return "too_small";
    case RingErrc::foreign:
      return "foreign";
    case RingErrc::wrong_version:
      return "wrong_version";
    case RingErrc::corrupt:
      return "corrupt";
    case RingErrc::owned_by_live_producer:
      return "owned_by_live_producer";
    case RingErrc::squatted:
      return "squatted";
    case RingErrc::no_space:
      return "no_space";
    case RingErrc::system:
      return "system";
  }
  return "unknown";
}

ErrorCategory category_of(RingErrc code) noexcept {
  switch (code) {
    case RingErrc::bad_config:
      return ErrorCategory::config;
    case RingErrc::too_small:
    case RingErrc::foreign:
    case RingErrc::wrong_version:
    case RingErrc::corrupt:
      return ErrorCategory::data;
    default:
      return ErrorCategory::environment;
  }
}

}  // namespace ioct::shm
