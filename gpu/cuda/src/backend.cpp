#include "ioct/gpu/cuda/backend.hpp"

#include "ioct/common/config_error.hpp"

namespace ioct::gpu {

std::string_view to_string(Backend backend) noexcept {
  switch (backend) {
    case Backend::cpu:
      return "cpu";
    case Backend::cuda:
      return "cuda";
    case Backend::automatic:
      return "auto";
  }
  return "?";
}

Backend parse_backend(std::string_view text) {
  if (text == "cpu") return Backend::cpu;
  if (text == "cuda") return Backend::cuda;
  if (text == "auto") return Backend::automatic;
  throw ConfigError("backend", "'" + std::string(text) + "'", "must be cpu, cuda or auto");
}

std::optional<std::string> cuda_unavailable_reason() {
#if IOCT_GPU_WITH_CUDA
  return cuda_device_problem();
#else
  return "this ioct-gpu was built without CUDA";
#endif
}

Backend resolve_backend(Backend requested, std::string* warning) {
  if (requested != Backend::automatic) return requested;
  if (const std::optional<std::string> reason = cuda_unavailable_reason()) {
    if (warning != nullptr) *warning = "backend auto: using the CPU (" + *reason + ")";
    return Backend::cpu;
  }
  return Backend::cuda;
}

}  // namespace ioct::gpu
