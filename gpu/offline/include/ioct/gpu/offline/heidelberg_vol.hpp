// Heidelberg Engineering .vol files (Spectralis "HSF-OCT-1xx" raw export), read by our own code
// from the layout that public readers document:
//
//   file header, 2048 bytes, little-endian: "HSF-OCT-1xx" version (12 bytes), size_x (A-scans
//     per B-scan), number of B-scans, size_y (pixels per A-scan) as u32 at 12, 16, 20; scale_x,
//     distance (between B-scans), scale_y as f64 at 24, 32, 40 (mm); SLO size x, y as u32 at 48,
//     52; SLO scale x, y f64 at 56, 64; field size u32 at 72; scan focus f64 at 76; scan position
//     ("OD"/"OS") 4 bytes at 84; exam time u64 at 88; scan pattern i32 at 96 (1 line, 2 circle,
//     3/4 volume, 5 radial); B-scan header size u32 at 100; IDs, patient and visit fields (not
//     read: nothing of the patient leaves this reader); thickness grid type and offset u32 at 208,
//     212.
//   SLO image: size_x_slo x size_y_slo u8, row-major.
//   per B-scan: a header of B-scan-header-size bytes: "HSF-BS-1xx" (12), header size u32 at 12,
//     start x, y, end x, y f64 at 16..40 (mm; a circle's end is its centre), number of
//     segmentation lines u32 at 48, their offset in the header u32 at 52 (256), quality f32 at
//     56, shift i32 at 60; then the lines, each size_x f32: the depth (in pixels from the top) of
//     ILM, BM (Bruch's membrane), RNFL (its outer boundary), ... at each A-scan, a value above
//     3e38 meaning "none here". Then the B-scan: size_y rows of size_x f32, row 0 at the top,
//     linear intensity in [0, 1], 3.4e38 (FLT_MAX) where there is no data.
//
// The u8 volume shows intensity as 255 * v^(1/4) (0 where there is no data): the fourth root is
// the display transform of the Spectralis viewer that public readers reproduce; a log scale is
// the alternative some use.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu::offline {

struct VolHeader {
  std::string version;       // "HSF-OCT-103"
  std::uint32_t ascans = 0;  // size_x
  std::uint32_t bscans = 0;
  std::uint32_t depth = 0;       // size_y
  double ascan_spacing_mm = 0;   // scale_x
  double bscan_distance_mm = 0;  // 0 for a single line or circle
  double depth_spacing_mm = 0;   // scale_y
  std::uint32_t slo_width = 0;
  std::uint32_t slo_height = 0;
  double slo_spacing_x_mm = 0;
  double slo_spacing_y_mm = 0;
  std::int32_t scan_pattern = 0;
  std::string scan_position;  // "OD" (right eye) or "OS" (left eye)
  std::uint32_t bscan_header_bytes = 0;
};

struct VolBscan {
  double start_x_mm = 0, start_y_mm = 0, end_x_mm = 0, end_y_mm = 0;
  float quality = 0;
  std::int32_t shift = 0;
  // [line][ascan]: depth in pixels from the top of the B-scan; NaN where the device drew none.
  std::vector<std::vector<float>> layers;
  std::vector<float> intensity;  // depth rows of ascans, as stored (FLT_MAX: no data)
};

struct HeidelbergVol {
  VolHeader header;
  std::vector<std::uint8_t> slo;  // slo_height rows of slo_width
  std::vector<VolBscan> bscans;
};

// Throws InputFileError naming the file, the field or B-scan, and the problem: not a .vol file
// (magic), a version other than HSF-OCT-1xx, sizes out of range, non-finite or non-positive
// scales, a B-scan header that contradicts the file header, segmentation lines that do not fit
// their header, a truncated file (which B-scan is cut), or bytes after the last B-scan that no
// thickness grid accounts for.
HeidelbergVol read_heidelberg_vol(const std::filesystem::path& path);

// The B-scans as a u8 volume [bscan][ascan][depth] (see above for the intensity mapping).
Volume to_volume(const HeidelbergVol& vol);

// "ILM", "BM", "RNFL" for lines 0, 1, 2; "line<k>" for the others, which this reader does not
// name.
std::string layer_name(std::size_t index);

// "circle", "line", ... for the header's scan pattern.
std::string_view scan_pattern_name(std::int32_t pattern) noexcept;

}  // namespace ioct::gpu::offline
