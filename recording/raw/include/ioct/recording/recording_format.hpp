// The raw recording format: groups of raw spectra as the digitizer delivered them, their
// acquisition status, and (for simulated recordings) the ground truth, in files that any tool
// can read without this library (numpy.memmap, MATLAB fread). docs/recording-format.md is the
// specification; this header is its C++ side.
//
// A recording named STEM is three files side by side:
//   STEM.json   metadata (this format's name and version, geometry, calibration, provenance)
//   STEM.raw    group records, each a 64-byte GroupRecordHeader then the group's samples
//   STEM.truth  (optional) one GroupTruth record per group
// All binary fields are little-endian.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include "ioct/common/error.hpp"

namespace ioct::recording {

inline constexpr const char* kFormatName = "ioct-raw-recording";
inline constexpr std::uint32_t kFormatVersion = 1;
inline constexpr std::size_t kGroupHeaderBytes = 64;
inline constexpr std::size_t kTruthHeaderBytes = 64;
inline constexpr std::array<char, 8> kGroupMagic{'I', 'O', 'C', 'T', 'G', 'R', 'P', '1'};
inline constexpr std::array<char, 8> kTruthMagic{'I', 'O', 'C', 'T', 'T', 'R', 'U', '1'};
inline constexpr std::size_t kToolStateFloats = 6;

// Bits of RecordedGroupInfo::status: the digitizer's GroupInfo flags (hal/digitizer.hpp).
inline constexpr std::uint32_t kStatusOverrun = 1u << 0;
inline constexpr std::uint32_t kStatusClockFault = 1u << 1;
inline constexpr std::uint32_t kStatusMissedTriggers = 1u << 2;
inline constexpr std::uint32_t kStatusTimeout = 1u << 3;
inline constexpr std::uint32_t kStatusDeviceLost = 1u << 4;

// Any problem with a recording's files: the message names the file and what is wrong with it.
class RecordingError : public std::runtime_error, public Error {
 public:
  explicit RecordingError(const std::string& what)
      : std::runtime_error(what), Error(ErrorCategory::data) {}
};

struct RecordingGeometry {
  std::uint32_t samples_per_ascan = 1376;
  std::uint32_t ascans_per_bscan = 512;
  std::uint32_t flyback_sweeps = 26;
  std::uint32_t bscans_per_group = 16;
  std::uint32_t bscans_per_volume = 128;
  double ascan_rate_hz = 100'000.0;
  std::uint32_t sample_bits = 12;
  std::string clock_source = "external_k_clock";  // or "internal"

  std::uint64_t ascans_per_group() const noexcept {
    return std::uint64_t{ascans_per_bscan} * bscans_per_group;
  }
  std::uint64_t samples_per_group() const noexcept {
    return ascans_per_group() * samples_per_ascan;
  }
  std::uint64_t sweeps_per_group() const noexcept {
    return (std::uint64_t{ascans_per_bscan} + flyback_sweeps) * bscans_per_group;
  }
  friend bool operator==(const RecordingGeometry&, const RecordingGeometry&) = default;
};

// The scan pattern the groups were recorded with, so that a reader can place each B-scan.
struct RecordingScan {
  std::string pattern = "raster";  // lines along x, stepping in y once per B-scan
  bool bidirectional = false;      // the odd B-scans of each volume run right to left
  double center_x = 0.0;           // scan units: [-1, 1] spans the field
  double center_y = 0.0;
  double extent_x = 1.0;  // half-width of a line
  double extent_y = 1.0;  // half-height of a volume
  friend bool operator==(const RecordingScan&, const RecordingScan&) = default;
};

struct RecordingMetadata {
  RecordingGeometry geometry;
  RecordingScan scan;
  // Where each k-linear sample lies in the raw record (gpu/ resampling.hpp convention):
  // x(j) = (N - 1) * sum c_n t^n, t = j / (N - 1). {0, 1}: already k-linear.
  std::vector<double> resampling_coefficients{0.0, 1.0};
  // Dispersion mismatch of the recording (gpu/ dispersion.hpp convention), 0 when unknown.
  double dispersion_c2 = 0.0;
  double dispersion_c3 = 0.0;
  std::string producer;     // what wrote it, e.g. "ioct-sim-record 0.1.0"
  std::string created_utc;  // ISO 8601; the writer fills it when empty
  nlohmann::json acquisition = nlohmann::json::object();  // free-form provenance
  bool has_truth = false;
  std::uint32_t truth_tools = 0;  // instruments per truth record

  friend bool operator==(const RecordingMetadata&, const RecordingMetadata&) = default;
};

// What the acquisition said about one group (the 64-byte header before its samples).
struct RecordedGroupInfo {
  std::uint64_t group_index = 0;  // 0, 1, 2, ... in file order
  std::uint64_t first_sweep_counter = 0;
  std::uint32_t missed_sweeps = 0;
  std::uint32_t status = 0;          // kStatus* bits
  std::uint64_t first_sweep_ns = 0;  // CLOCK_MONOTONIC of the first and last sweep, 0 if unknown
  std::uint64_t last_sweep_ns = 0;
  friend bool operator==(const RecordedGroupInfo&, const RecordedGroupInfo&) = default;
};

// Where an instrument was, for the ground truth.
struct ToolState {
  float tip_x = 0.0f;  // scan units
  float tip_y = 0.0f;
  float tip_depth_px = 0.0f;  // px of the processed depth axis (samples_per_ascan / 2 px)
  float yaw_deg = 0.0f;
  float pitch_deg = 0.0f;
  float jaw_opening_deg = 0.0f;
};

// The ground truth of one group: per recorded A-scan ([bscan][ascan], ascans_per_bscan x
// bscans), the depths at which the ILM, the RPE and an instrument's surface were drawn (px of
// the processed depth axis; NaN where absent) and where the beam actually was (scan units); per
// B-scan and instrument, the instrument's pose at the B-scan's first sweep.
struct GroupTruth {
  std::uint64_t group_index = 0;
  std::uint64_t first_sweep_counter = 0;
  std::uint32_t ascans_per_bscan = 0;
  std::uint32_t bscans = 0;
  std::uint32_t tools = 0;
  std::vector<float> ilm_px;
  std::vector<float> rpe_px;
  std::vector<float> tool_px;
  std::vector<float> beam_x;
  std::vector<float> beam_y;
  std::vector<ToolState> tool_states;  // [bscan][tool]

  // Sizes every array (allocates; do it before acquisition).
  void resize(std::uint32_t ascans, std::uint32_t bscan_count, std::uint32_t tool_count);
  std::size_t ascans() const noexcept { return std::size_t{ascans_per_bscan} * bscans; }
  // Bytes of one truth record in the file.
  static std::uint64_t record_bytes(std::uint32_t ascans, std::uint32_t bscan_count,
                                    std::uint32_t tool_count) noexcept;
};

// Byte-exact equality (NaN equals NaN): what a round trip must preserve.
bool same_bytes(const GroupTruth& a, const GroupTruth& b) noexcept;

// Group record stride in STEM.raw.
inline std::uint64_t group_stride_bytes(const RecordingGeometry& geometry) noexcept {
  return kGroupHeaderBytes + 2 * geometry.samples_per_group();
}

// The metadata as the JSON file holds it, and back (validated: RecordingError naming `source`
// and the key).
nlohmann::json to_json(const RecordingMetadata& metadata);
RecordingMetadata metadata_from_json(const nlohmann::json& json, const std::string& source);

// The UTC time now as "2026-11-22T12:34:56Z".
std::string utc_now();

}  // namespace ioct::recording
