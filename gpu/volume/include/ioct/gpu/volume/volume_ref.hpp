// Where a volume's bytes live, as the later stages (filters, segmentation, rendering) take it: a
// host Volume, or a device pointer with the stream its bytes are ordered on. CPU stages take host
// refs; CUDA stages take both: device refs are worked on in place, enqueued on the ref's stream
// with no host copy and no synchronisation, host refs through the stage's upload path.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "ioct/gpu/volume/volume.hpp"

struct CUstream_st;

namespace ioct::gpu {

// Dimensions of a u8 volume [bscan][ascan][depth], depth contiguous, no padding.
struct VolumeDims {
  std::uint32_t bscans = 0, ascans = 0, depth = 0;
  std::size_t bscan_bytes() const noexcept { return std::size_t{ascans} * depth; }
  std::size_t bytes() const noexcept { return bscans * bscan_bytes(); }
  static VolumeDims of(const Volume& v) noexcept { return {v.bscans(), v.ascans(), v.depth()}; }
  friend bool operator==(const VolumeDims&, const VolumeDims&) = default;
};

// The device volume as a reader sees it (the CUDA live pipeline's volume).
struct DeviceVolumeView {
  const std::uint8_t* pixels = nullptr;  // device memory [bscan][ascan][depth]
  std::uint32_t bscans = 0;
  std::uint32_t ascans = 0;
  std::uint32_t depth = 0;
  std::uint64_t version = 0;  // groups written into it since the pipeline started
};

template <class Pixel, class HostVolume>
class BasicVolumeRef {
 public:
  static BasicVolumeRef on_host(HostVolume& volume) noexcept {
    BasicVolumeRef r;
    r.dims_ = VolumeDims::of(volume);
    r.host_ = &volume;
    return r;
  }
  // `pixels`: device memory of dims.bytes(), valid in the order of work on `stream`.
  static BasicVolumeRef on_device(Pixel* pixels, VolumeDims dims, CUstream_st* stream) noexcept {
    BasicVolumeRef r;
    r.dims_ = dims;
    r.device_ = pixels;
    r.stream_ = stream;
    return r;
  }

  bool is_device() const noexcept { return host_ == nullptr; }
  const VolumeDims& dims() const noexcept { return dims_; }
  // Throw std::logic_error when asked for the other kind.
  HostVolume& host() const {
    if (host_ == nullptr) throw std::logic_error("a device volume was used as a host volume");
    return *host_;
  }
  Pixel* device() const {
    if (host_ != nullptr) throw std::logic_error("a host volume was used as a device volume");
    return device_;
  }
  CUstream_st* stream() const noexcept { return stream_; }

 private:
  BasicVolumeRef() = default;
  VolumeDims dims_;
  HostVolume* host_ = nullptr;
  Pixel* device_ = nullptr;
  CUstream_st* stream_ = nullptr;
};

// A volume a stage reads, and one it writes.
using VolumeRef = BasicVolumeRef<const std::uint8_t, const Volume>;
using MutableVolumeRef = BasicVolumeRef<std::uint8_t, Volume>;

}  // namespace ioct::gpu
