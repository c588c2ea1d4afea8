// Where offline processing reads raw spectra from: a plain u16 file whose dimensions the command
// line gives (RawSpectraFile), or one volume of a raw recording (RecordingVolume). Both hand out
// one volume of B-scans [bscan][ascan][sample] in the host's byte order.
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace ioct::gpu::offline {

struct RawSpectraLayout;  // raw_spectra_file.hpp

class SpectraSource {
 public:
  virtual ~SpectraSource() = default;
  // samples_per_ascan, ascans_per_bscan and bscans (of the one volume) are what processing uses.
  virtual const RawSpectraLayout& layout() const noexcept = 0;
  // Reads B-scans [first, first + count) into `out` (count x ascans x samples values). Throws
  // std::out_of_range for a bad range or size and InputFileError when a read fails.
  virtual void read_bscans(std::uint32_t first, std::uint32_t count,
                           std::span<std::uint16_t> out) const = 0;
  // What it is, for messages and the volume's provenance ("run1.raw", "volume 2 of run1").
  virtual std::string describe() const = 0;
};

}  // namespace ioct::gpu::offline
