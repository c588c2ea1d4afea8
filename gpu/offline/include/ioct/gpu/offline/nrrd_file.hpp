// NRRD files of u8 volumes: the format 3D Slicer, Fiji (ImageJ) and ITK open directly, with one
// short text header in front of the raw voxels.
//
// Written (NRRD0004, "raw" encoding, attached data):
//   NRRD0004
//   # ioct volume: u8 [bscan][ascan][depth], depth fastest
//   type: uint8
//   dimension: 3
//   sizes: <depth> <ascans> <bscans>
//   spacings: <depth> <ascan> <bscan>
//   units: "mm" "mm" "mm"                 (when the spacings have a unit)
//   kinds: domain domain domain
//   labels: "depth" "ascan" "bscan"
//   content: <what it is>                 (optional)
//   encoding: raw
//   <key>:=<value>                        (optional key/value pairs)
//   <blank line, then depth x ascans x bscans bytes>
//
// Read back: only what we write is accepted, and everything else is refused with the field and
// the reason: magic NRRD0001..5, type uint8 (or its synonyms), dimension 3, three positive sizes,
// raw encoding, attached data (no "data file"), no byte or line skip, spacings finite and
// positive (or nan), and exactly the bytes the sizes need after the header.
#pragma once

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu::offline {

struct NrrdMetadata {
  // Distance between neighbouring voxels along depth, A-scans and B-scans, in `unit`; NaN for
  // unknown (written as nan).
  std::array<double, 3> spacings{1.0, 1.0, 1.0};
  std::string unit;     // e.g. "mm"; empty: no units line
  std::string content;  // one line saying what the volume is; empty: none
  std::vector<std::pair<std::string, std::string>> key_values;  // single-line keys and values
};

// Header and voxels to `stream`. Throws std::invalid_argument for metadata that cannot be
// written (a newline in a value, a key with ":=", a negative or infinite spacing) and
// std::runtime_error when writing fails.
void write_nrrd(std::FILE* stream, const Volume& volume, const NrrdMetadata& metadata);

// The same into `path` through an AtomicFile: the file appears complete or not at all.
void write_nrrd_file(const std::filesystem::path& path, const Volume& volume,
                     const NrrdMetadata& metadata);

struct NrrdVolume {
  Volume volume;
  NrrdMetadata metadata;
};

// Throws InputFileError naming the file, the field and the problem.
NrrdVolume read_nrrd_file(const std::filesystem::path& path);

}  // namespace ioct::gpu::offline
