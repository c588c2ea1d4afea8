// Which backend runs a stage: the CPU reference or CUDA, and whether CUDA can run on this
// machine. Every stage (processing, filters, segmentation, instruments, render) is made for a
// Backend by its make_*() and throws BackendUnavailable for one the build or machine lacks.
// Needs no CUDA headers: the question is asked in builds without CUDA too.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include "ioct/common/error.hpp"

namespace ioct::gpu {

enum class Backend {
  cpu,
  cuda,
  automatic,  // "auto": cuda when a usable device is present, else cpu
};

std::string_view to_string(Backend backend) noexcept;
// Throws ConfigError("backend", ...) naming the accepted values.
Backend parse_backend(std::string_view text);

// Why the cuda backend cannot run here ("built without CUDA", "no CUDA device", "compute
// capability 7.5 is not supported by this build ..."), or nothing when it can.
std::optional<std::string> cuda_unavailable_reason();

// cpu or cuda for `requested`: automatic becomes cuda when cuda_unavailable_reason() is empty,
// else cpu, and then `warning` (when given) says why.
Backend resolve_backend(Backend requested, std::string* warning = nullptr);

// Why the cuda backend cannot run on this machine (no driver, no GPU, a GPU this build has no
// code for, with the rebuild flag), or nothing when it can. Only in builds with CUDA.
std::optional<std::string> cuda_device_problem();

class BackendUnavailable : public std::runtime_error, public Error {
 public:
  explicit BackendUnavailable(const std::string& what)
      : std::runtime_error(what), Error(ErrorCategory::config) {}
};

}  // namespace ioct::gpu
