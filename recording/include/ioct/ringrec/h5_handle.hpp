// An HDF5 identifier that closes itself, and the error translation every HDF5 call goes through.
// HDF5 (Debian's serial build) is not thread-safe: one thread at a time uses a file and its
// objects; the recorder hands its file over to the writer thread before that thread starts.
#pragma once

#include <hdf5.h>

#include <stdexcept>
#include <string>
#include "ioct/common/error.hpp"

namespace ioct::ringrec {

// An HDF5 call that failed, with what the library said (the innermost messages of its stack).
class H5Error : public std::runtime_error, public Error {
 public:
  explicit H5Error(const std::string& what)
      : std::runtime_error(what), Error(ErrorCategory::data) {}
};

// The library's own error stack, as one line ("H5Dwrite_chunk: ... ; ..."); empty when none.
std::string h5_error_stack();

// Throws H5Error("what: <stack>") when `status` is negative.
herr_t h5_check(herr_t status, const std::string& what);
hid_t h5_check_id(hid_t id, const std::string& what);

// Turns HDF5's automatic printing of errors to stderr off (our messages say it instead).
void h5_quiet();

class H5Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  H5Handle() = default;
  H5Handle(hid_t id, Closer closer) noexcept : id_(id), closer_(closer) {}
  H5Handle(H5Handle&& other) noexcept : id_(other.id_), closer_(other.closer_) { other.id_ = -1; }
  H5Handle& operator=(H5Handle&& other) noexcept {
    if (this != &other) {
      reset();
      id_ = other.id_;
      closer_ = other.closer_;
      other.id_ = -1;
    }
    return *this;
  }
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  ~H5Handle() { reset(); }

  hid_t get() const noexcept { return id_; }
  explicit operator bool() const noexcept { return id_ >= 0; }
  void reset() noexcept {
    if (id_ >= 0 && closer_ != nullptr) closer_(id_);
    id_ = -1;
  }
  // Closes now and reports a failure (a file's close writes its last metadata).
  void close(const std::string& what) {
    const hid_t id = id_;
    id_ = -1;
    if (id >= 0 && closer_ != nullptr) h5_check(closer_(id), what);
  }

 private:
  hid_t id_ = -1;
  Closer closer_ = nullptr;
};

}  // namespace ioct::ringrec
