// ioct-vol-import: a Heidelberg Spectralis .vol export -> NRRD volume, CSV of the device's
// segmentation lines, PNG of a B-scan and of the SLO image; a Bioptigen .OCT export -> NRRD volume
// (each position's frames averaged) and PNG of a B-scan. The format is told by the file's magic.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "ioct/common/atomic_file.hpp"
#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/gpu/offline/bioptigen_oct.hpp"
#include "ioct/gpu/offline/heidelberg_vol.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/offline/input_format.hpp"
#include "ioct/gpu/offline/layer_csv.hpp"
#include "ioct/gpu/offline/nrrd_file.hpp"
#include "ioct/gpu/offline/progress_bar.hpp"
#include "ioct/gpu/volume/png_file.hpp"
#include "ioct/gpu/volume/projections.hpp"

namespace fs = std::filesystem;
using namespace ioct::gpu;
using namespace ioct::gpu::offline;

namespace {

// The values the flags fill.
struct Options {
  std::string input, out_dir = ".", name;
  int bscan = -1;
  std::optional<std::uint32_t> repeat;
};

// The B-scan shown (the centre one unless --bscan) and the outputs' path stem. Throws a
// ConfigError (told by run_command, exit 2) when the B-scan lies outside the file's `count`
// (`what`: "B-scan positions", "B-scans") or the output folder is missing.
struct Target {
  int bscan = 0;
  fs::path base;
};
Target choose_target(const Options& o, std::uint32_t count, const char* what) {
  Target t;
  t.bscan = o.bscan < 0 ? static_cast<int>(count / 2) : o.bscan;
  if (t.bscan >= static_cast<int>(count)) {
    throw ioct::ConfigError(
        "--bscan", std::to_string(t.bscan),
        "the file has " + std::to_string(count) + " " + what + ", counted from 0");
  }
  if (!fs::is_directory(o.out_dir)) {
    throw ioct::ConfigError("--out", ioct::format_text(o.out_dir), "must be an existing directory");
  }
  t.base = fs::path(o.out_dir) / (o.name.empty() ? fs::path(o.input).stem().string() : o.name);
  return t;
}

// Bioptigen .OCT: the NRRD (spacings in mm where the file states the lengths) and a B-scan PNG.
int import_bioptigen(const Options& o, std::vector<fs::path>& committed) {
  const BioptigenOct oct = read_bioptigen_oct(o.input);
  const BioptigenHeader& h = oct.header;
  if (o.repeat && *o.repeat >= oct.repeats) {
    throw ioct::ConfigError(
        "--repeat", std::to_string(*o.repeat),
        "the file has " + std::to_string(oct.repeats) + " frame(s) per position, counted from 0");
  }
  const Target target = choose_target(o, oct.positions, "B-scan positions");
  const int bscan = target.bscan;
  const fs::path nrrd_path = target.base.string() + ".nrrd";
  const fs::path bscan_path = target.base.string() + "_bscan.png";

  const BioptigenVolume imported = to_volume(oct, o.repeat);
  const BioptigenSpacingMm mm = spacing_mm(oct);
  const std::string frames =
      o.repeat ? "frame " + std::to_string(*o.repeat) + " of " + std::to_string(oct.repeats)
               : "mean of " + std::to_string(oct.repeats) + " frame(s)";
  NrrdMetadata metadata;
  const bool lengths = mm.depth > 0 && mm.ascan > 0;
  const bool known_bscan = lengths && mm.bscan > 0;
  if (lengths) {
    metadata.spacings = {mm.depth, mm.ascan, known_bscan ? mm.bscan : mm.ascan};
    metadata.unit = "mm";
  }
  metadata.content = "Bioptigen .OCT " + std::string(bioptigen_scan_type_name(h.scan_type)) +
                     " scan, " + frames + " per position, u16 window " +
                     std::to_string(imported.window_low) + ".." +
                     std::to_string(imported.window_high) + " -> 0..255";
  metadata.key_values = {
      {"ioct_source", fs::path(o.input).filename().string()},
      {"ioct_bioptigen_scan_type", std::to_string(h.scan_type)},
      {"ioct_bioptigen_frames", frames},
      {"ioct_bioptigen_window",
       std::to_string(imported.window_low) + " " + std::to_string(imported.window_high)},
      {"ioct_spacing", !lengths      ? "unknown (the file states no SCANDEPTH or scan length)"
                       : known_bscan ? "from the file"
                                     : "B-scan spacing unknown (A-scan spacing written)"}};

  // Everything is written before anything is committed: on any failure no output is left.
  ioct::AtomicFile nrrd(nrrd_path);
  write_nrrd(nrrd.stream(), imported.volume, metadata);
  write_png_gray8(bscan_path, bscan_image(imported.volume, static_cast<std::uint32_t>(bscan)));
  committed.push_back(bscan_path);
  nrrd.commit();
  committed.clear();

  std::cout << o.input << ": Bioptigen .OCT version 0x" << std::hex << h.version << std::dec << ", "
            << bioptigen_scan_type_name(h.scan_type) << " scan, " << oct.positions
            << " B-scan position(s) x " << oct.repeats << " frame(s) of " << h.ascans
            << " A-scans x " << h.depth << " px";
  if (mm.ascan > 0) std::cout << ", " << mm.ascan * 1000 << " um between A-scans";
  if (mm.depth > 0) std::cout << ", " << mm.depth * 1000 << " um/px";
  if (mm.bscan > 0) std::cout << ", " << mm.bscan * 1000 << " um between B-scans";
  if (!h.description.empty()) std::cout << ", \"" << h.description << "\"";
  std::cout << "\n  " << frames << " per position, u16 window " << imported.window_low << ".."
            << imported.window_high << "\nvolume: " << nrrd_path.string()
            << "\nbscan:  " << bscan_path.string() << "\n";
  return EXIT_SUCCESS;
}

// The command line: the input, where the outputs go and what the PNG shows.
void add_options(CLI::App& app, Options& o) {
  app.option_defaults()->always_capture_default();
  app.add_option("input", o.input, "the .vol or .OCT file")->required();
  app.add_option("--out", o.out_dir, "directory for the outputs (must exist)");
  app.add_option("--name", o.name, "file name stem of the outputs (default: the input's)");
  app.add_option("--bscan", o.bscan, "B-scan shown in the PNG (default: the centre one)");
  app.add_option("--repeat", o.repeat,
                 "Bioptigen only: take frame N of each position instead of the mean of all");
}

// Where a Heidelberg import's outputs go, all named after one stem.
struct HeidelbergOutputs {
  fs::path nrrd, csv, bscan, slo;
};

// The NRRD header of a Heidelberg volume: its spacings in mm and where it came from.
NrrdMetadata heidelberg_metadata(const std::string& input, const VolHeader& h) {
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
  return metadata;
}

// What was imported: the scan, how much of each segmentation line the device drew, the outputs.
void print_heidelberg_summary(const std::string& input, const HeidelbergVol& vol,
                              const HeidelbergOutputs& outputs) {
  const VolHeader& h = vol.header;
  const bool known_distance = h.bscan_distance_mm > 0;
  std::size_t lines = 0;
  for (const VolBscan& b : vol.bscans) lines = std::max(lines, b.layers.size());
  std::cout << input << ": " << h.version << ", " << scan_pattern_name(h.scan_pattern) << " scan, "
            << h.bscans << " B-scan(s) of " << h.ascans << " A-scans x " << h.depth << " px, "
            << h.ascan_spacing_mm * 1000 << " um x " << h.depth_spacing_mm * 1000 << " um/px";
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
  std::cout << "volume: " << outputs.nrrd.string() << "\nlayers: " << outputs.csv.string()
            << "\nbscan:  " << outputs.bscan.string() << "\n";
  if (h.slo_width > 0 && h.slo_height > 0) {
    std::cout << "slo:    " << outputs.slo.string() << "\n";
  }
}

// Heidelberg .vol: the NRRD (spacings in mm), the layer CSV, a B-scan PNG and the SLO PNG.
int import_heidelberg(const Options& o, std::vector<fs::path>& committed) {
  if (o.repeat) {
    throw ioct::ConfigError("--repeat", std::to_string(*o.repeat),
                            "applies to Bioptigen .OCT files only");
  }
  const HeidelbergVol vol = read_heidelberg_vol(o.input);
  const VolHeader& h = vol.header;
  const Target target = choose_target(o, h.bscans, "B-scans");
  const int bscan = target.bscan;
  const fs::path& base = target.base;
  const HeidelbergOutputs outputs{base.string() + ".nrrd", base.string() + "_layers.csv",
                                  base.string() + "_bscan.png", base.string() + "_slo.png"};

  ProgressBar progress(stderr, "ioct-vol-import", "B-scans", h.bscans,
                       ProgressBar::stderr_is_terminal());
  const Volume volume = to_volume(vol);
  progress.finish();
  const NrrdMetadata metadata = heidelberg_metadata(o.input, h);

  // Everything is written before anything is committed: on any failure no output is left.
  ioct::AtomicFile nrrd(outputs.nrrd);
  write_nrrd(nrrd.stream(), volume, metadata);
  ioct::AtomicFile csv(outputs.csv);
  write_layer_csv(csv.stream(), vol);
  write_png_gray8(outputs.bscan, bscan_image(volume, static_cast<std::uint32_t>(bscan)));
  committed.push_back(outputs.bscan);
  if (h.slo_width > 0 && h.slo_height > 0) {
    write_png_gray8(outputs.slo, h.slo_width, h.slo_height, vol.slo);
    committed.push_back(outputs.slo);
  }
  nrrd.commit();
  committed.push_back(outputs.nrrd);
  csv.commit();
  committed.clear();

  print_heidelberg_summary(o.input, vol, outputs);
  return EXIT_SUCCESS;
}

// The import of either format; on a failure the outputs already committed are removed again.
int import_file(const Options& o) {
  std::vector<fs::path> committed;  // removed again if a later output fails
  try {
    const InputFormat format = detect_input_format(o.input);
    if (format == InputFormat::bioptigen_oct) return import_bioptigen(o, committed);
    if (format != InputFormat::heidelberg_vol) {
      throw InputFileError(o.input,
                           "neither a Heidelberg .vol (it does not start with HSF-OCT-) nor a "
                           "Bioptigen .OCT (magic number 0x0C7DA7A5) file");
    }
    return import_heidelberg(o, committed);
  } catch (const std::exception&) {
    // Told as every command tells it (run_command); the files already written go first, so
    // nothing half imported is left.
    for (const fs::path& path : committed) {
      std::error_code ignored;
      fs::remove(path, ignored);
    }
    throw;
  }
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{
      "ioct-vol-import: Heidelberg .vol -> NRRD volume, layer CSV and PNG images; Bioptigen .OCT "
      "-> NRRD volume and PNG. The format is detected by the file's magic number (HSF-OCT- or "
      "0x0C7DA7A5), not by its extension."};
  add_options(app, options);
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;
  return ioct::run_command("ioct-vol-import", [&]() -> int { return import_file(options); });
}
