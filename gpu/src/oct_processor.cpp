#include "ioct/gpu/oct_processor.hpp"

#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/cpu_oct_processor.hpp"

namespace ioct::gpu {

void OctProcessorConfig::validate() const {
  background.validate();
  window.validate();
  fft.validate();
  scale.validate();
  require_real_in_range("threads", threads, 1, 16);
}

std::string_view to_string(Backend backend) noexcept {
  switch (backend) {
    case Backend::cpu:
      return "cpu";
    case Backend::cuda:
      return "cuda";
  }
  return "?";
}

Backend parse_backend(std::string_view text) {
  if (text == "cpu") return Backend::cpu;
  if (text == "cuda") return Backend::cuda;
  throw ConfigError("backend", "'" + std::string(text) + "'", "must be cpu or cuda");
}

std::unique_ptr<OctProcessor> make_oct_processor(Backend backend,
                                                 const OctProcessorConfig& config) {
  config.validate();
  switch (backend) {
    case Backend::cpu:
      return std::make_unique<CpuOctProcessor>(config);
    case Backend::cuda:
      // The CUDA stages are not part of this build (no CUDA implementation is compiled in yet).
      throw BackendUnavailable(
          "backend cuda: this ioct-gpu was built without CUDA; use --backend cpu");
  }
  throw ConfigError("backend", std::to_string(static_cast<int>(backend)), "must be cpu or cuda");
}

}  // namespace ioct::gpu
