// ioct-segment: the ILM and RPE of a volume file (NRRD as ioct-process and ioct-vol-import write
// it, a Heidelberg .vol export or a Bioptigen .OCT file), with the same segmentation as the live
// system. Writes the surfaces as CSV (one row per A-scan, px and um) and overlay PNGs of B-scans.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "ioct/common/atomic_file.hpp"
#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/common/log.hpp"
#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/offline/volume_file.hpp"
#include "ioct/gpu/segmentation/overlay_image.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"
#include "ioct/gpu/segmentation/surfaces_csv.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ioct::gpu;
using namespace ioct::gpu::segmentation;

std::vector<std::uint32_t> overlay_bscans(const std::string& which, const Surfaces& surfaces) {
  std::vector<std::uint32_t> list;
  if (surfaces.bscans == 0) return list;
  if (which == "centre" || which == "center") {
    list.push_back(surfaces.bscans / 2);
  } else if (which == "all") {
    for (std::uint32_t b = 0; b < surfaces.bscans; ++b) list.push_back(b);
  } else if (which != "none") {
    char* end = nullptr;
    const unsigned long b = std::strtoul(which.c_str(), &end, 10);
    if (which.empty() || *end != '\0' || b >= surfaces.bscans) {
      throw ioct::ConfigError(
          "overlay", "'" + which + "'",
          "must be centre, all, none or a B-scan index below " + std::to_string(surfaces.bscans));
    }
    list.push_back(static_cast<std::uint32_t>(b));
  }
  return list;
}

// The values the flags fill.
struct Options {
  std::string input;
  std::string out = ".";
  std::string backend_text = "auto";
  std::string filter = "auto";
  std::string overlay = "centre";
  std::optional<double> axial_um;
  std::optional<double> ascan_um;
  std::optional<double> bscan_um;
  unsigned threads = 2;
  SegmentationConfig config;
};

// The command line: the input, the outputs, the spacings and the segmentation's settings.
void add_options(CLI::App& app, Options& o) {
  app.add_option(
         "input", o.input,
         "volume file: .nrrd (ioct-process, ioct-vol-import), Heidelberg .vol or Bioptigen .OCT "
         "(told apart by their contents)")
      ->required();
  app.add_option("--out", o.out, "directory for surfaces.csv, overlay_bscan<N>.png, summary.json");
  app.add_option("--backend", o.backend_text, "cpu, cuda or auto (cuda when a device is usable)");
  app.add_option("--filter", o.filter,
                 "median 3x3x3 + Gaussian 5x5 before segmenting: auto (unless the NRRD says it "
                 "was filtered), yes or no");
  app.add_option("--overlay", o.overlay, "B-scans drawn: centre, all, none or an index");
  app.add_option("--axial-um", o.axial_um, "depth px spacing, um (default: from the file)");
  app.add_option("--ascan-um", o.ascan_um, "A-scan spacing, um (default: from the file)");
  app.add_option("--bscan-um", o.bscan_um, "B-scan spacing, um (default: from the file)");
  app.add_option("--threads", o.threads, "CPU threads (cpu backend and filters)");
  app.add_option("--max-thickness-um", o.config.retina_max_thickness_um,
                 "largest ILM-to-RPE distance searched");
  app.add_option("--max-slope", o.config.max_slope, "largest surface slope, um depth per um");
  app.add_option("--ilm-level", o.config.ilm_level, "ILM at this share of the rise to its reflex");
}

// --filter, --threads and the segmentation's settings, refused before the volume is read.
void check_options(const Options& o) {
  if (o.filter != "auto" && o.filter != "yes" && o.filter != "no") {
    throw ioct::ConfigError("filter", "'" + o.filter + "'", "must be auto, yes or no");
  }
  if (o.threads < 1 || o.threads > 64) {
    throw ioct::ConfigError("threads", ioct::format_value(std::uint64_t{o.threads}),
                            "must be in [1, 64]");
  }
  o.config.validate();
}

// The voxel spacings: the file's, each overridden by its flag; a warning when neither gives all.
VolumeSampling sampling_of(const Options& o, const offline::VolumeFile& loaded) {
  VolumeSampling sampling;
  if (loaded.spacing) {
    sampling.axial_um_per_px = loaded.spacing->axial_per_px;
    sampling.ascan_spacing_um = loaded.spacing->ascan;
    sampling.bscan_spacing_um = loaded.spacing->bscan;
  }
  if (o.axial_um) sampling.axial_um_per_px = *o.axial_um;
  if (o.ascan_um) sampling.ascan_spacing_um = *o.ascan_um;
  if (o.bscan_um) sampling.bscan_spacing_um = *o.bscan_um;
  if (!loaded.spacing && !(o.axial_um && o.ascan_um && o.bscan_um)) {
    std::ostringstream line;
    line << o.input << ": the file states no spacings in mm or um; using the default geometry's ("
         << sampling.axial_um_per_px << " um/px, " << sampling.ascan_spacing_um << " um, "
         << sampling.bscan_spacing_um << " um); give --axial-um, --ascan-um and --bscan-um";
    ioct::Log("ioct-segment").warning(line.str());
  }
  sampling.validate();
  return sampling;
}

// A finished segmentation and how it was made, as the outputs report it.
struct Segmentation {
  const offline::VolumeFile& loaded;
  const Volume& volume;  // the one segmented: the loaded volume or its filtered copy
  const VolumeSampling& sampling;
  const Surfaces& surfaces;
  std::string_view backend;
  bool filtered;
  double seconds;
};

// The overlay PNGs --overlay asks for; returns their names.
std::vector<std::string> write_overlays(const Options& o, const Segmentation& s) {
  std::vector<std::string> pngs;
  for (const std::uint32_t b : overlay_bscans(o.overlay, s.surfaces)) {
    char name[64];
    std::snprintf(name, sizeof name, "overlay_bscan%03u.png", b);
    write_png_rgb8(fs::path(o.out) / name, make_overlay(s.volume, b, s.surfaces));
    pngs.emplace_back(name);
  }
  return pngs;
}

// surfaces.csv, the overlays, summary.json and the one line that sums them up.
void write_outputs(const Options& o, const Segmentation& s) {
  const Volume& volume = s.volume;
  const VolumeSampling& sampling = s.sampling;
  const Surfaces& surfaces = s.surfaces;
  fs::create_directories(o.out);
  const fs::path csv = fs::path(o.out) / "surfaces.csv";
  {
    ioct::AtomicFile file(csv);
    write_surfaces_csv(file.stream(), surfaces, sampling.axial_um_per_px);
    file.commit();
  }
  const std::vector<std::string> pngs = write_overlays(o, s);
  std::size_t counts[3] = {0, 0, 0};
  for (const SurfaceState state : surfaces.state) ++counts[static_cast<int>(state)];
  std::size_t retina = 0;
  for (const BscanVerdict v : surfaces.verdict) retina += v == BscanVerdict::retina ? 1 : 0;
  const nlohmann::json summary = {
      {"input", fs::path(o.input).filename().string()},
      {"kind", s.loaded.kind},
      {"backend", std::string(s.backend)},
      {"filtered", s.filtered},
      {"bscans", volume.bscans()},
      {"ascans", volume.ascans()},
      {"depth", volume.depth()},
      {"sampling_um",
       {{"axial_per_px", sampling.axial_um_per_px},
        {"ascan_spacing", sampling.ascan_spacing_um},
        {"bscan_spacing", sampling.bscan_spacing_um}}},
      {"bscans_with_retina", retina},
      {"ascans_measured", counts[static_cast<int>(SurfaceState::measured)]},
      {"ascans_bridged", counts[static_cast<int>(SurfaceState::bridged)]},
      {"ascans_none", counts[static_cast<int>(SurfaceState::none)]},
      {"seconds", s.seconds},
      {"csv", csv.filename().string()},
      {"overlays", pngs}};
  ioct::write_text_file_atomically(fs::path(o.out) / "summary.json", summary.dump(2) + "\n");
  std::cout << "ioct-segment: " << o.input << " (" << s.loaded.kind << ", " << volume.bscans()
            << " x " << volume.ascans() << " x " << volume.depth() << "): " << retina << " of "
            << volume.bscans() << " B-scans with a retina; A-scans measured "
            << counts[static_cast<int>(SurfaceState::measured)] << ", bridged "
            << counts[static_cast<int>(SurfaceState::bridged)] << ", none "
            << counts[static_cast<int>(SurfaceState::none)] << "; " << s.backend << ", "
            << s.seconds << " s -> " << csv.string() << "\n";
}

// The command's work: settings, the volume, its (filtered) segmentation and the outputs.
int segment(const Options& o) {
  const Backend backend = parse_backend(o.backend_text);
  check_options(o);

  const offline::VolumeFile loaded = offline::read_volume_file(o.input);
  const VolumeSampling sampling = sampling_of(o, loaded);

  const auto start = std::chrono::steady_clock::now();
  const bool do_filter = o.filter == "yes" || (o.filter == "auto" && !loaded.already_filtered);
  Volume filtered;
  if (do_filter && loaded.volume.bscans() > 0) {
    filters::make_volume_filter(backend, {}, o.threads)->filter_volume(loaded.volume, filtered);
  }
  const Volume& volume = do_filter && loaded.volume.bscans() > 0 ? filtered : loaded.volume;
  const std::unique_ptr<Segmenter> segmenter =
      make_segmenter(backend, o.config, sampling, o.threads);
  Surfaces surfaces;
  segmenter->segment_volume(volume, surfaces);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  write_outputs(
      o, {loaded, volume, sampling, surfaces, segmenter->backend_name(), do_filter, seconds});
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{
      "ioct-segment: ILM and RPE of a volume file (.nrrd, Heidelberg .vol or Bioptigen .OCT) as "
      "CSV and overlay PNGs"};
  add_options(app, options);
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;
  return ioct::run_command("ioct-segment", [&]() -> int { return segment(options); });
}
