// The OCT processing chain as one interface: raw spectra of a group in, u8 B-scans out.
//
//   background removal -> window -> FFT (real to complex) -> log magnitude -> u8 (dB range)
//   -> flip of reversed lines
//
// CpuOctProcessor (FFTW) is the reference; a CUDA implementation (cuFFT) implements the same
// interface and is tested against it.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string_view>

#include "ioct/gpu/background_removal.hpp"
#include "ioct/gpu/db_scale.hpp"
#include "ioct/gpu/fftw_r2c_plan.hpp"
#include "ioct/gpu/processed_group.hpp"
#include "ioct/gpu/spectral_window.hpp"
#include "ioct/shm/ring_geometry.hpp"
#include "ioct/shm/ring_layout.hpp"

namespace ioct::gpu {

struct OctProcessorConfig {
  BackgroundConfig background;
  WindowConfig window;
  FftConfig fft;
  DbScaleConfig scale;
  // Threads that process a group's B-scans, the caller's included. One core processes about
  // 140k A-scans/s of the default geometry, too little margin over the 100k/s acquisition on a
  // shared machine; two halve the time per group.
  std::uint32_t threads = 2;

  // Throws ConfigError naming the first bad key; threads in [1, 16].
  void validate() const;
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

  // Sizes buffers and makes FFT plans for `geometry`; call again when it changes. Throws
  // std::invalid_argument for a geometry the chain cannot process (see require_processable).
  virtual void prepare(const shm::RingGeometry& geometry) = 0;

  // Processes the group's active A-scans into `out` (resized; no allocation once its capacity
  // has grown to a group). Throws std::invalid_argument for a group find_group_problem rejects
  // and std::logic_error before prepare().
  virtual void process(const RawGroup& group, ProcessedGroup& out) = 0;

  virtual std::string_view backend_name() const noexcept = 0;
};

enum class Backend { cpu, cuda };

std::string_view to_string(Backend backend) noexcept;
// Throws ConfigError("backend", ...) naming the accepted values.
Backend parse_backend(std::string_view text);

// Throws ConfigError for a bad config and BackendUnavailable for a backend this build lacks.
std::unique_ptr<OctProcessor> make_oct_processor(Backend backend, const OctProcessorConfig& config);

class BackendUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace ioct::gpu
