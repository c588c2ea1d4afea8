// The one error type of the ring: a code a program can act on and a message a person can read.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

#include "ioct/common/error.hpp"

namespace ioct::shm {

enum class RingErrc {
  bad_config,              // a geometry or config value is out of range; the message names it
  not_found,               // no object of that name
  permission,              // the object exists but this process may not open or map it
  not_ready,               // the producer is still initialising the object: try again shortly
  producer_gone,           // the producer closed or retired the object: reattach
  too_small,               // the object is shorter than its header or than the header says
  foreign,                 // the object does not start with the ring's magic
  wrong_version,           // a ring of another layout version
  corrupt,                 // the header contradicts itself; the message names the field
  owned_by_live_producer,  // another running producer owns the name
  squatted,  // something not ours (another user's file, a FIFO, a link) holds the name
  no_space,  // the file system holding the objects has too little room for the ring
  system,    // an operating-system call failed; the message names it
};

std::string_view to_string(RingErrc code) noexcept;

// The category (ioct/common/error.hpp) of a ring error with this code: bad_config is config, a
// damaged or foreign object is data, the rest (missing, not ready, rights, room) environment.
ErrorCategory category_of(RingErrc code) noexcept;

class RingError : public std::runtime_error, public Error {
 public:
  RingError(RingErrc code, const std::string& message)
      : std::runtime_error(message), Error(category_of(code)), code_(code) {}
  RingErrc code() const noexcept { return code_; }

 private:
  RingErrc code_;
};

}  // namespace ioct::shm
