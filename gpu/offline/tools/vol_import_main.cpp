// ioct-vol-import: a Heidelberg Spectralis .vol export -> NRRD volume, CSV of the device's
// segmentation lines, PNG of a B-scan and of the SLO image.
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "ioct/common/atomic_file.hpp"
#include "ioct/gpu/offline/heidelberg_vol.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/offline/layer_csv.hpp"
#include "ioct/gpu/offline/nrrd_file.hpp"
#include "ioct/gpu/offline/progress_bar.hpp"
#include "ioct/gpu/png_file.hpp"
#include "ioct/gpu/projections.hpp"

namespace fs = std::filesystem;
using namespace ioct::gpu;
using namespace ioct::gpu::offline;

int main(int argc, char** argv) {
  std::string input, out_dir = ".", name;
  int bscan = -1;
  CLI::App app{"ioct-vol-import: Heidelberg .vol -> NRRD volume, layer CSV and PNG images"};
  app.option_defaults()->always_capture_default();
  app.add_option("input", input, "the .vol file")->required();
  app.add_option("--out", out_dir, "directory for the outputs (must exist)");
  app.add_option("--name", name, "file name stem of the outputs (default: the input's)");
  app.add_option("--bscan", bscan, "B-scan shown in the PNG (default: the centre one)");
  CLI11_PARSE(app, argc, argv);

  std::vector<fs::path> committed;  // removed again if a later output fails
  try {
    const HeidelbergVol vol = read_heidelberg_vol(input);
    const VolHeader& h = vol.header;
    if (bscan < 0) bscan = static_cast<int>(h.bscans / 2);
    if (bscan >= static_cast<int>(h.bscans)) {
      std::cerr << "ioct-vol-import: invalid option: --bscan " << bscan << " (the file has "
                << h.bscans << " B-scans)\n";
      return 2;
    }
    if (!fs::is_directory(out_dir)) {
      std::cerr << "ioct-vol-import: output directory '" << out_dir << "' does not exist\n";
      return 1;
    }
    if (name.empty()) name = fs::path(input).stem().string();
    const fs::path base = fs::path(out_dir) / name;
    const fs::path nrrd_path = base.string() + ".nrrd";
    const fs::path csv_path = base.string() + "_layers.csv";
    const fs::path bscan_path = base.string() + "_bscan.png";
    const fs::path slo_path = base.string() + "_slo.png";

    ProgressBar progress(stderr, "ioct-vol-import", "B-scans", h.bscans,
                         ProgressBar::stderr_is_terminal());
    const Volume volume = to_volume(vol);
    progress.finish();

    NrrdMetadata metadata;
    // A single line or circle has no B-scan spacing: the A-scan spacing stands in for it, and
    // the header says so.
    const bool known_distance = h.bscan_distance_mm > 0;
    metadata.spacings = {h.depth_spacing_mm, h.ascan_spacing_mm,
                         known_distance ? h.bscan_distance_mm : h.ascan_spacing_mm};
    metadata.unit = "mm";
    metadata.content = "Heidelberg " + h.version + " " +
                       std::string(scan_pattern_name(h.scan_pattern)) +
                       " scan, intensity 255 * v^(1/4)";
    metadata.key_values = {{"ioct_source", fs::path(input).filename().string()},
                           {"ioct_scan_pattern", std::to_string(h.scan_pattern)},
                           {"ioct_bscan_spacing",
                            known_distance ? "from the file" : "unknown (A-scan spacing written)"}};

    // Everything is written before anything is committed: on any failure no output is left.
    ioct::AtomicFile nrrd(nrrd_path);
    write_nrrd(nrrd.stream(), volume, metadata);
    ioct::AtomicFile csv(csv_path);
    write_layer_csv(csv.stream(), vol);
    write_png_gray8(bscan_path, bscan_image(volume, static_cast<std::uint32_t>(bscan)));
    committed.push_back(bscan_path);
    if (h.slo_width > 0 && h.slo_height > 0) {
      write_png_gray8(slo_path, h.slo_width, h.slo_height, vol.slo);
      committed.push_back(slo_path);
    }
    nrrd.commit();
    committed.push_back(nrrd_path);
    csv.commit();
    committed.clear();

    std::size_t lines = 0;
    for (const VolBscan& b : vol.bscans) lines = std::max(lines, b.layers.size());
    std::cout << input << ": " << h.version << ", " << scan_pattern_name(h.scan_pattern)
              << " scan, " << h.bscans << " B-scan(s) of " << h.ascans << " A-scans x " << h.depth
              << " px, " << h.ascan_spacing_mm * 1000 << " um x " << h.depth_spacing_mm * 1000
              << " um/px";
    if (known_distance) std::cout << ", " << h.bscan_distance_mm * 1000 << " um between B-scans";
    std::cout << "\n";
    for (std::size_t l = 0; l < lines; ++l) {
      std::size_t drawn = 0, total = 0;
      for (const VolBscan& b : vol.bscans) {
        if (l >= b.layers.size()) continue;
        total += b.layers[l].size();
        for (float v : b.layers[l]) drawn += std::isnan(v) ? 0 : 1;
      }
      std::cout << "  line " << layer_name(l) << ": drawn at " << drawn << " of " << total
                << " A-scans\n";
    }
    std::cout << "volume: " << nrrd_path.string() << "\nlayers: " << csv_path.string()
              << "\nbscan:  " << bscan_path.string() << "\n";
    if (h.slo_width > 0 && h.slo_height > 0) std::cout << "slo:    " << slo_path.string() << "\n";
    return EXIT_SUCCESS;
  } catch (const InputFileError& e) {
    std::cerr << "ioct-vol-import: bad input: " << e.what() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "ioct-vol-import: error: " << e.what() << "\n";
  }
  for (const fs::path& path : committed) {
    std::error_code ignored;
    fs::remove(path, ignored);
  }
  return 1;
}
