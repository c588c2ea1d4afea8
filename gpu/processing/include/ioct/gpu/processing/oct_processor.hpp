// The OCT processing chain as one interface: raw spectra of a group in, u8 B-scans out.
//
//   rolling background removal -> [lambda -> k resampling] -> window x [dispersion phase]
//   -> FFT (real to complex; complex to complex with dispersion) -> log magnitude
//   -> [mean power of repeated B-scans] -> u8 (dB range) -> flip of reversed lines
//
// CpuOctProcessor (FFTW) is the reference; CudaOctProcessor (cuFFT) implements the same
// interface and is tested against it: the same u8 pixels to within 1 LSB on at least 99.9% of
// them (the two differ only in their FFT's rounding; see README.md).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "ioct/gpu/cuda/backend.hpp"
#include "ioct/gpu/processing/background_removal.hpp"
#include "ioct/gpu/processing/db_scale.hpp"
#include "ioct/gpu/processing/dispersion.hpp"
#include "ioct/gpu/processing/fftw_r2c_plan.hpp"
#include "ioct/gpu/processing/resampling.hpp"
#include "ioct/gpu/processing/spectral_window.hpp"
#include "ioct/gpu/volume/processed_group.hpp"
#include "ioct/shm/ring_geometry.hpp"
#include "ioct/shm/ring_layout.hpp"

namespace ioct::gpu {

struct OctProcessorConfig {
  BackgroundConfig background;
  ResamplingConfig resampling;
  WindowConfig window;
  DispersionConfig dispersion;
  FftConfig fft;
  DbScaleConfig scale;
  // B-scans acquired at each position, one after the other in a group, averaged (in power, so
  // speckle and noise average too) into one output B-scan. 1: no repeats. See repeats.hpp.
  std::uint32_t repeats_per_position = 1;
  // Threads that process a group's B-scans on the CPU, the caller's included. One core
  // processes about 140k A-scans/s of the default geometry, too little margin over the 100k/s
  // acquisition on a shared machine; two halve the time per group. Unused by CUDA.
  std::uint32_t threads = 2;

  // Throws ConfigError naming the first bad key; threads in [1, 16], repeats in [1, 16].
  void validate() const;
  // Also checks what depends on the geometry: the resampling calibration over its sweep, and
  // repeats dividing bscans_per_group and bscans_per_volume. Throws ConfigError.
  void validate_for(const shm::RingGeometry& geometry) const;
};

// A group as read from the ring: its header and its spectra, u16 little-endian
// [bscan][record][sample] with samples contiguous.
struct RawGroup {
  const shm::SlotHeader& header;
  std::span<const std::uint16_t> spectra;
};

class OctProcessor {
 public:
  virtual ~OctProcessor() = default;

  // Sizes buffers and makes FFT plans for `geometry`; call again when it changes. Forgets the
  // background history. Throws std::invalid_argument for a geometry the chain cannot process
  // (see require_processable) and ConfigError for a config that does not fit it
  // (validate_for).
  virtual void prepare(const shm::RingGeometry& geometry) = 0;

  // Processes the group's active A-scans into `out` (resized; no allocation once its capacity
  // has grown to a group). Groups must come in acquisition order: the rolling background
  // remembers the last ones. Throws std::invalid_argument for a group find_group_problem
  // rejects and std::logic_error before prepare().
  virtual void process(const RawGroup& group, ProcessedGroup& out) = 0;
  // The dB range of the groups processed from now on (the assistant's control): only the u8
  // mapping changes, nothing is re-planned. Throws ConfigError naming db_min or db_max.
  virtual void set_db_range(const DbScaleConfig& scale) = 0;

  virtual std::string_view backend_name() const noexcept = 0;
};

// Throws ConfigError for a bad config and BackendUnavailable for a backend this build or
// machine lacks (naming why).
std::unique_ptr<OctProcessor> make_oct_processor(Backend backend, const OctProcessorConfig& config);

}  // namespace ioct::gpu
