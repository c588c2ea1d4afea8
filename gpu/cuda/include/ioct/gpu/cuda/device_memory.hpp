// The GPU's memory as the CUDA driver reports it, for the live figures (/metrics). Absent, not
// zero, where there is no device: a build without CUDA, or no usable GPU.
#pragma once

#include <cstdint>
#include <optional>

namespace ioct::gpu {

struct DeviceMemory {
  std::uint64_t used_bytes = 0;  // by every process on the device, this one included
  std::uint64_t total_bytes = 0;
};

// The current device's memory; nullopt without CUDA or when the query fails.
std::optional<DeviceMemory> device_memory() noexcept;

}  // namespace ioct::gpu
