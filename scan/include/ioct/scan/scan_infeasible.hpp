// The error of a pattern the scanner cannot follow: which limit, where in the pattern, by how
// much, and what would make it feasible.
#pragma once

#include <stdexcept>
#include <string>

#include "ioct/common/error.hpp"

namespace ioct::scan {

// Category config; its key is the limit's.
class ScanInfeasible : public std::invalid_argument, public Error {
 public:
  // `limit`: the config key of the limit ("galvo.max_acceleration", "scan.field", ...);
  // `required` and `allowed` in the limit's units; `message` the whole sentence.
  ScanInfeasible(std::string limit, double required, double allowed, const std::string& message)
      : std::invalid_argument(message),
        Error(ErrorCategory::config, limit),
        limit_(std::move(limit)),
        required_(required),
        allowed_(allowed) {}

  const std::string& limit() const noexcept { return limit_; }
  double required() const noexcept { return required_; }
  double allowed() const noexcept { return allowed_; }

 private:
  std::string limit_;
  double required_;
  double allowed_;
};

}  // namespace ioct::scan
