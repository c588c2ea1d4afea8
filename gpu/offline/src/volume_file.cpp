#include "ioct/gpu/offline/volume_file.hpp"

#include <cctype>
#include <cmath>
#include <string_view>

#include "ioct/gpu/offline/bioptigen_oct.hpp"
#include "ioct/gpu/offline/heidelberg_vol.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/offline/input_format.hpp"
#include "ioct/gpu/offline/nrrd_file.hpp"

namespace ioct::gpu::offline {
namespace {

bool has_extension(const std::filesystem::path& path, std::string_view extension) {
  std::string e = path.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e == extension;
}

double micrometres_per_unit(const std::string& unit) {
  if (unit == "mm") return 1000.0;
  if (unit == "um" || unit == "\u00b5m" || unit == "micron") return 1.0;
  return 0.0;  // unknown or none
}

}  // namespace

VolumeFile read_volume_file(const std::filesystem::path& path) {
  VolumeFile file;
  // A Bioptigen export is told by its magic: its ".OCT" is shared with other vendors.
  if (detect_input_format(path) == InputFormat::bioptigen_oct) {
    const BioptigenOct oct = read_bioptigen_oct(path);
    file.volume = to_volume(oct).volume;
    const BioptigenSpacingMm mm = spacing_mm(oct);
    if (mm.depth > 0.0 && mm.ascan > 0.0) {
      file.spacing = VoxelSpacingUm{mm.depth * 1000.0, mm.ascan * 1000.0,
                                    (mm.bscan > 0.0 ? mm.bscan : mm.ascan) * 1000.0};
    }
    file.kind =
        "Bioptigen .OCT (" + std::string(bioptigen_scan_type_name(oct.header.scan_type)) + ")";
    return file;
  }
  if (has_extension(path, ".vol")) {
    HeidelbergVol vol = read_heidelberg_vol(path);
    file.volume = to_volume(vol);
    const VolHeader& h = vol.header;
    const double ascan_um = h.ascan_spacing_mm * 1000.0;
    file.spacing =
        VoxelSpacingUm{h.depth_spacing_mm * 1000.0, ascan_um,
                       h.bscan_distance_mm > 0.0 ? h.bscan_distance_mm * 1000.0 : ascan_um};
    file.kind = "Heidelberg .vol (" + std::string(scan_pattern_name(h.scan_pattern)) + ")";
    file.vol_layers.reserve(vol.bscans.size());
    for (VolBscan& b : vol.bscans) file.vol_layers.push_back(std::move(b.layers));
    return file;
  }
  if (has_extension(path, ".nrrd") || has_extension(path, ".nhdr")) {
    NrrdVolume nrrd = read_nrrd_file(path);
    file.volume = std::move(nrrd.volume);
    const NrrdMetadata& m = nrrd.metadata;
    const double to_um = micrometres_per_unit(m.unit);
    if (to_um > 0.0 && std::isfinite(m.spacings[0]) && std::isfinite(m.spacings[1]) &&
        std::isfinite(m.spacings[2])) {
      file.spacing =
          VoxelSpacingUm{m.spacings[0] * to_um, m.spacings[1] * to_um, m.spacings[2] * to_um};
    }
    for (const auto& [key, value] : m.key_values) {
      if (key == "ioct_filter" && value != "none") file.already_filtered = true;
    }
    file.kind = "NRRD";
    return file;
  }
  throw InputFileError(path,
                       "not a volume file this command reads: use .nrrd, .vol or a Bioptigen .OCT");
}

}  // namespace ioct::gpu::offline
