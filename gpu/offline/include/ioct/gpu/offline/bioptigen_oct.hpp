// Bioptigen (Envisu, InVivoVue) processed .OCT files, read by our own code from the layout that
// public readers document: Bioptigen's own ImageJ plugin OCT_Reader (B. Bower, 2010, "Oct File
// Format x010A"), its MATLAB original extractOctFunction.m as ported to Python
// (readBioptigenOct), and OCT-Converter's oct_converter/readers/binary_structs/boct_binary.py.
// The magic number is the one OCT-Converter's maintainer reports from a real file (issue #77).
//
//   u32 magic 0x0C7DA7A5 (bytes A5 A7 7D 0C), u16 version (0x010A seen), all little-endian.
//   Then tagged fields: u32 key length, the key (ASCII), u32 data length, the data.
//   File header: the marker FRAMEHEADER (a data length, no data), then FRAMECOUNT, LINECOUNT
//     (A-scans per frame), LINELENGTH (samples per A-scan), SAMPLEFORMAT (u32), DESCRIPTION (text),
//     XMIN, XMAX (f64), XCAPTION, YMIN, YMAX, YCAPTION, SCANTYPE (u32: 0 linear, 1 rectangular
//     volume, 3 radial, 5 M-mode, 6 mixed density), SCANDEPTH, SCANLENGTH, AZSCANLENGTH,
//     ELSCANLENGTH, OBJECTDISTANCE, SCANANGLE (f64, lengths in mm), SCANS (B-scan positions;
//     FRAMESPERVOLUME before v1.7), FRAMES (frames per position, v1.7 and later), DOPPLERFLAG,
//     CONFIG (text), SUBFRAME* (version 105) ...; ended by a key length of 0.
//   Per frame: the marker FRAMEDATA (a data length, no data), FRAMEDATETIME (SYSTEMTIME: 8 u16),
//     FRAMETIMESTAMP (f64), FRAMELINES (u32), FRAMESAMPLES (FRAMELINES x LINELENGTH u16, each
//     A-scan's samples contiguous, the first at the top), DOPPLERSAMPLES (when DOPPLERFLAG, the
//     same size); ended by a key length of 0.
//   Frames come as whole volumes: frame f is B-scan position f % SCANS of repeat f / SCANS (as
//   OCT-Converter orders them); a linear or M-mode scan repeats one position.
//
// Used: the counts, SCANTYPE, the lengths, DOPPLERFLAG, DESCRIPTION, FRAMELINES, FRAMESAMPLES.
// Kept but not interpreted: SAMPLEFORMAT (every public reader takes u16). Skipped by their data
// length: XMIN..YCAPTION, OBJECTDISTANCE, SCANANGLE, the frame times, CONFIG ("obfuscated"),
// DOPPLERSAMPLES, SUBFRAME* and any key not known.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu::offline {

inline constexpr std::uint32_t kBioptigenMagic = 0x0C7DA7A5;

struct BioptigenHeader {
  std::uint16_t version = 0;
  std::uint32_t frame_count = 0;  // FRAMECOUNT: frames in the file
  std::uint32_t ascans = 0;       // LINECOUNT
  std::uint32_t depth = 0;        // LINELENGTH
  std::uint32_t sample_format = 0;
  std::uint32_t scan_type = 0;
  std::optional<std::uint32_t> scans;            // SCANS, or FRAMESPERVOLUME in older files
  std::optional<std::uint32_t> frames_per_scan;  // FRAMES
  bool doppler = false;
  double scan_depth_mm = 0, scan_length_mm = 0;  // 0: not in the file
  double az_scan_length_mm = 0, el_scan_length_mm = 0;
  std::string description;  // quoted for display (quote_input)
};

struct BioptigenOct {
  BioptigenHeader header;
  std::uint32_t positions = 0;  // B-scan positions (1 for a linear or M-mode scan)
  std::uint32_t repeats = 0;    // frames at each position (averaged into one B-scan)
  // [frame][ascan][sample], the file's u16 values (log intensity as the device saved it).
  std::vector<std::uint16_t> samples;
};

// Whether `head` (the file's first bytes) starts with the Bioptigen magic number.
bool has_bioptigen_magic(const std::uint8_t* head, std::size_t size) noexcept;

// Throws InputFileError naming the file, the field and its byte offset: another magic, a
// truncated header or frame, sizes out of range or larger than the file (checked before
// anything is allocated), fields of the wrong length or out of range, FRAMECOUNT that disagrees
// with SCANS x FRAMES or with the frames present, a frame whose FRAMELINES or FRAMESAMPLES
// disagree with the header, mixed-density scans (SCANTYPE 6), and bytes after the last frame.
BioptigenOct read_bioptigen_oct(const std::filesystem::path& path);

struct BioptigenVolume {
  Volume volume;  // [position][ascan][sample]
  // The u16 window mapped to 0..255: the 0.5th and 99.9th percentile of the B-scans.
  std::uint16_t window_low = 0, window_high = 0;
};

// The B-scans as a u8 volume: each position's frames averaged (or only repeat `repeat`), then
// the u16 values mapped linearly from the window to 0..255 (they are log intensity already).
// Throws std::out_of_range for a repeat the file does not have.
BioptigenVolume to_volume(const BioptigenOct& oct, std::optional<std::uint32_t> repeat = {});

// Voxel spacing in mm where the file states the lengths (0 where it does not): depth
// SCANDEPTH / LINELENGTH; A-scans AZSCANLENGTH (rectangular; else SCANLENGTH) / LINECOUNT;
// B-scans ELSCANLENGTH / SCANS for a rectangular volume of more than one position.
struct BioptigenSpacingMm {
  double depth = 0, ascan = 0, bscan = 0;
};
BioptigenSpacingMm spacing_mm(const BioptigenOct& oct) noexcept;

// "linear", "rectangular volume", "radial", "M-mode", ... for SCANTYPE.
std::string_view bioptigen_scan_type_name(std::uint32_t scan_type) noexcept;

}  // namespace ioct::gpu::offline
