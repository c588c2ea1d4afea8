// A volume file as the offline commands (ioct-segment, ioct-render) read it: a NRRD as
// ioct-process and ioct-vol-import write it, a Heidelberg .vol export or a Bioptigen .OCT export
// (each position's frames averaged), with the voxel spacing when the file states it.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu::offline {

struct VoxelSpacingUm {
  double axial_per_px = 0.0;
  double ascan = 0.0;
  double bscan = 0.0;  // a single .vol B-scan or circle has none: the A-scan spacing stands in
};

struct VolumeFile {
  Volume volume;
  std::optional<VoxelSpacingUm> spacing;  // none: the NRRD states no spacings in mm or um
  bool already_filtered = false;          // the NRRD's ioct_filter key names a filter
  std::string kind;                       // "NRRD", "Heidelberg .vol (circle)", ...
  // A .vol's own segmentation lines, [bscan][line][ascan] in px (line 0 ILM, 1 Bruch's
  // membrane; NaN where the device drew none); empty for a NRRD.
  std::vector<std::vector<std::vector<float>>> vol_layers;
};

// A Bioptigen .OCT by its magic number (whatever its extension), the others by the extension
// (.nrrd, .nhdr, .vol; any case). Throws InputFileError naming the file and the problem, also
// for another extension.
VolumeFile read_volume_file(const std::filesystem::path& path);

}  // namespace ioct::gpu::offline
