// Files for the offline tests: a scratch directory, synthetic raw spectra with reflectors at known
// depths, synthetic Heidelberg .vol files written from the documented layout, and running the
// offline commands as processes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace ioct::gpu::offline::testing {

// A fresh directory under the system's temporary directory, removed with everything in it.
class ScratchDir {
 public:
  ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir();
  const std::filesystem::path& path() const noexcept { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
  // Names of the entries in it, sorted (hidden temporaries included).
  std::vector<std::string> entries() const;

 private:
  std::filesystem::path path_;
};

struct SpectraSpec {
  std::uint32_t samples = 256;
  std::uint32_t ascans = 32;
  std::uint32_t bscans = 20;
  // Depth bin (cycles per sweep) of the one reflector at B-scan b, A-scan a.
  std::function<double(std::uint32_t b, std::uint32_t a)> depth = [](std::uint32_t, std::uint32_t) {
    return 40.0;
  };
  double amplitude = 60.0;  // fringe amplitude, ADC counts
  // Raw sample i is taken where the k-linear sweep is at position position(i) (in samples):
  // identity for a k-clock; the inverse of a calibration polynomial for lambda-linear sampling.
  std::function<double(std::uint32_t i)> position = [](std::uint32_t i) { return double(i); };
  std::uint32_t seed = 1;
};

// u16 spectra [bscan][ascan][sample]: a source spectrum (the same every sweep), the reflector's
// fringe with a random phase per A-scan, and noise of 2 counts, 12-bit range.
std::vector<std::uint16_t> make_spectra(const SpectraSpec& spec);

// Writes `values` as u16 in the given byte order (little: true), after `header_bytes` zeros.
void write_u16_file(const std::filesystem::path& path, const std::vector<std::uint16_t>& values,
                    bool little_endian, std::size_t header_bytes = 0);

// The raw position x(j) of output sample j for calibration coefficients c (the chain's
// convention, ioct/gpu/resampling.hpp), inverted: the k-linear position of raw sample i.
double inverse_calibration_position(const std::vector<double>& c, std::uint32_t samples,
                                    std::uint32_t i);

struct VolSpec {
  std::uint32_t ascans = 8, depth = 6, bscans = 2;
  std::uint32_t slo_width = 4, slo_height = 3;
  std::uint32_t lines = 3;
  std::uint32_t bscan_header_bytes = 256 + 3 * 8 * 4 + 16;  // 16 spare bytes
  double scale_x = 0.0117, distance = 0.12, scale_y = 0.0039;
  std::int32_t scan_pattern = 3;
};

// Intensity of pixel (depth row y, A-scan x) of B-scan b, and line l at A-scan x, as the synthetic
// file stores them (FLT_MAX at a few places: no data / no line).
float vol_intensity(std::uint32_t b, std::uint32_t y, std::uint32_t x);
float vol_line(std::uint32_t b, std::uint32_t l, std::uint32_t x);

// A complete .vol file for `spec`, as bytes (tests cut and patch them).
std::vector<std::uint8_t> make_vol_bytes(const VolSpec& spec);
void write_bytes(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes);

struct ToolResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// Runs `executable` with `arguments`, stdout and stderr into files of `dir`; waits up to 60 s.
ToolResult run_tool(const std::string& executable, const std::vector<std::string>& arguments,
                    const std::filesystem::path& dir);

std::string read_text(const std::filesystem::path& path);
std::vector<std::uint8_t> read_bytes(const std::filesystem::path& path);

// The depth test data of the design brief (Heidelberg .vol), or an empty path when this checkout
// does not have it.
std::filesystem::path spectralis_vol_file();

}  // namespace ioct::gpu::offline::testing
