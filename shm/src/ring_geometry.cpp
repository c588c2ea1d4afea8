#include "ioct/shm/ring_geometry.hpp"

#include <string>

#include "ioct/shm/ring_error.hpp"

namespace ioct::shm {
namespace {

void require_range(const char* key, std::uint64_t value, std::uint64_t lo, std::uint64_t hi) {
  if (value < lo || value > hi) {
    throw RingError(RingErrc::bad_config, "ring geometry: " + std::string(key) + " = " +
                                              std::to_string(value) + " is out of range [" +
                                              std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
}

}  // namespace

void RingGeometry::validate() const {
  require_range("samples_per_ascan", samples_per_ascan, 1, 1u << 16);
  require_range("ascans_per_bscan", ascans_per_bscan, 1, 1u << 16);
  require_range("bscans_per_group", bscans_per_group, 1, kMaxBscansPerGroup);
  require_range("bscans_per_volume", bscans_per_volume, 1, 1u << 16);
  if (bytes_per_sample != 1 && bytes_per_sample != 2 && bytes_per_sample != 4) {
    throw RingError(RingErrc::bad_config,
                    "ring geometry: bytes_per_sample = " + std::to_string(bytes_per_sample) +
                        " must be 1, 2 or 4");
  }
}

std::uint64_t RingGeometry::group_payload_bytes() const {
  std::uint64_t bytes = 0;
  if (__builtin_mul_overflow(std::uint64_t{samples_per_ascan}, std::uint64_t{ascans_per_bscan},
                             &bytes) ||
      __builtin_mul_overflow(bytes, std::uint64_t{bscans_per_group}, &bytes) ||
      __builtin_mul_overflow(bytes, std::uint64_t{bytes_per_sample}, &bytes)) {
    throw RingError(RingErrc::bad_config,
                    "ring geometry: samples_per_ascan x ascans_per_bscan x bscans_per_group x "
                    "bytes_per_sample overflows 64 bits");
  }
  return bytes;
}

}  // namespace ioct::shm
