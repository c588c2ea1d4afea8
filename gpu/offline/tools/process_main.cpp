// ioct-process: raw spectra recorded to a file -> a volume (NRRD), through the same processing
// chain (and, when asked, the same filters) as the live system. The input is either a plain u16
// file whose dimensions the options give, a raw recording (STEM.json + STEM.raw, see
// docs/recording-format.md), whose metadata gives the dimensions and how to process it, or an
// HDF5 ring recording (ioct-record), whose geometry and slot headers give the dimensions and the
// volumes.
#include <CLI/CLI.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "ioct/common/atomic_file.hpp"
#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/common/log.hpp"
#include "ioct/gpu/offline/calibration_file.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/offline/nrrd_file.hpp"
#include "ioct/gpu/offline/raw_processing.hpp"
#include "ioct/gpu/offline/recording_volume.hpp"
#include "ioct/gpu/offline/ring_recording_volume.hpp"
#include "ioct/gpu/processing/resampling.hpp"
#include "ioct/gpu/volume/png_file.hpp"
#include "ioct/gpu/volume/projections.hpp"

namespace {

using namespace ioct::gpu;
using namespace ioct::gpu::offline;

// "0.0056,0.012,0.05" -> three spacings in mm.
std::array<double, 3> parse_spacings(const std::string& text) {
  std::vector<std::string> parts(1);
  for (char c : text) {
    if (c == ',') {
      parts.emplace_back();
    } else {
      parts.back() += c;
    }
  }
  std::array<double, 3> spacings{};
  bool good = parts.size() == 3;
  for (std::size_t i = 0; good && i < 3; ++i) {
    char* end = nullptr;
    spacings[i] = std::strtod(parts[i].c_str(), &end);
    good = !parts[i].empty() && *end == '\0' && std::isfinite(spacings[i]) && spacings[i] > 0;
  }
  if (!good) {
    throw ioct::ConfigError("spacing_mm", "'" + text + "'",
                            "must be three positive numbers depth,ascan,bscan in mm");
  }
  return spacings;
}

// A recording when the input names its metadata (STEM.json), or when no dimensions are given and
// STEM.json lies beside it; a plain u16 file otherwise.
bool is_recording(const std::filesystem::path& input, bool dimensions_given) {
  if (input.extension() == ".json") return true;
  if (dimensions_given) return false;
  std::filesystem::path json = input;
  json.replace_extension(".json");
  return std::filesystem::exists(json);
}

// The settings ioct-process starts from, before the flags and a recording's metadata.
RawProcessingSettings one_volume_settings() {
  RawProcessingSettings settings;
  settings.processing.fft.rigor = FftRigor::estimate;  // one volume: planning time would dominate
  return settings;
}

// The values the flags fill, and the flags whose absence lets a recording's metadata decide.
struct Options {
  RawSpectraLayout layout;
  RawProcessingSettings settings = one_volume_settings();
  std::string input, output, png, byte_order = "little", backend = "cpu";
  std::string background = std::string(to_string(settings.processing.background.mode));
  std::string window = std::string(to_string(settings.processing.window.kind));
  std::string rigor = std::string(to_string(settings.processing.fft.rigor));
  std::string resample, poly, calibration_file, filter = "none", spacing;
  double sigma = ioct::gpu::filters::VolumeFilterConfig{}.gaussian_sigma;
  std::uint64_t volume_index = 0;
  // Set by add_options(): their count() says whether the flag was given.
  const CLI::Option* samples_option = nullptr;
  const CLI::Option* ascans_option = nullptr;
  const CLI::Option* bscans_option = nullptr;
  const CLI::Option* volume_option = nullptr;
  const CLI::Option* group_option = nullptr;
  const CLI::Option* bidirectional_option = nullptr;
  const CLI::Option* c2_option = nullptr;
  const CLI::Option* c3_option = nullptr;
};

// The command line: the input and its layout, the processing chain's settings and the outputs.
void add_options(CLI::App& app, Options& o) {
  RawSpectraLayout& layout = o.layout;
  RawProcessingSettings& settings = o.settings;
  app.option_defaults()->always_capture_default();
  app.add_option("input", o.input,
                 "raw spectra: u16 [bscan][ascan][sample], samples contiguous; or a raw "
                 "recording (STEM.json, or STEM with STEM.json beside it)")
      ->required();
  app.add_option("--out", o.output, "volume to write (.nrrd)")->required();
  o.samples_option = app.add_option("--samples", layout.samples_per_ascan,
                                    "samples per A-scan (even; raw files only)");
  o.ascans_option =
      app.add_option("--ascans", layout.ascans_per_bscan, "A-scans per B-scan (raw files only)");
  o.bscans_option =
      app.add_option("--bscans", layout.bscans, "B-scans in the file, one volume (raw files only)");
  o.volume_option = app.add_option("--volume", o.volume_index,
                                   "which volume of a recording, 0 first (recordings only; of "
                                   "an HDF5 ring recording: its N-th complete volume)");
  app.add_option("--byte-order", o.byte_order, "byte order of the samples: little or big");
  app.add_option("--header-bytes", layout.header_bytes, "bytes to skip at the start of the file");
  o.group_option = app.add_option("--bscans-per-group", settings.bscans_per_group,
                                  "B-scans per group, as the ring would carry them (1 to 64)");
  o.bidirectional_option =
      app.add_flag("--bidirectional", settings.bidirectional,
                   "odd B-scans were acquired right to left (they are flipped)");
  app.add_option("--backend", o.backend, "processing backend: cpu, cuda or auto");
  app.add_option("--threads", settings.processing.threads, "CPU threads (1 to 16)");
  app.add_option("--db-min", settings.processing.scale.db_min, "dB shown as black");
  app.add_option("--db-max", settings.processing.scale.db_max, "dB shown as white");
  app.add_option("--background", o.background, "background removal: rolling or none");
  app.add_option("--window", o.window, "spectral window: hann or rectangular");
  o.c2_option = app.add_option("--dispersion-c2", settings.processing.dispersion.c2,
                               "quadratic dispersion phase (rad at the sweep's ends)");
  o.c3_option = app.add_option("--dispersion-c3", settings.processing.dispersion.c3,
                               "cubic dispersion phase");
  app.add_option("--resample", o.resample,
                 "lambda -> k resampling: none, linear or cubic (default: cubic when a "
                 "calibration is given, else none)");
  app.add_option("--resample-poly", o.poly,
                 "calibration c0,c1,...: output sample j is read at raw position "
                 "(N-1) * sum c_i (j/(N-1))^i");
  app.add_option("--calibration-file", o.calibration_file,
                 "the calibration coefficients from a file (commas, spaces or newlines)");
  app.add_option("--fft-rigor", o.rigor, "FFTW planning: estimate, measure or patient");
  app.add_option("--filter", o.filter,
                 "after processing: none, median-gauss (3x3x3 median + 5x5 Gaussian) or "
                 "median-bscan (3x3 median per B-scan, Weiss 2019)");
  app.add_option("--sigma", o.sigma, "Gaussian sigma (px) of --filter median-gauss");
  app.add_option("--spacing-mm", o.spacing,
                 "voxel spacing depth,ascan,bscan in mm for the NRRD header (default: 1 px)");
  app.add_option("--png", o.png, "also write the centre B-scan as PNG");
}

// The flags' words turned into settings, refused before the input is opened.
void parse_settings(Options& o, const ioct::Log& log) {
  o.layout.byte_order = parse_byte_order(o.byte_order);
  std::string warning;
  o.settings.backend = resolve_backend(parse_backend(o.backend), &warning);
  if (!warning.empty()) log.warning(warning);
  o.settings.processing.background.mode = parse_background_mode(o.background);
  o.settings.processing.window.kind = parse_window_kind(o.window);
  o.settings.processing.fft.rigor = parse_fft_rigor(o.rigor);
  if (!o.poly.empty() && !o.calibration_file.empty()) {
    throw ioct::ConfigError("calibration", "--resample-poly and --calibration-file",
                            "give one of them, not both");
  }
}

// The opened input, and what a recording of either kind adds to it.
struct Input {
  std::unique_ptr<SpectraSource> source;
  const RecordingVolume* recording = nullptr;
  std::vector<double> recording_calibration;
  const RingRecordingVolume* ring_recording = nullptr;
};

// The input opened as what it is; a recording's metadata fills the settings the flags leave out.
Input open_input(Options& o) {
  RawProcessingSettings& settings = o.settings;
  const std::string& input = o.input;
  const bool dimensions_given =
      o.samples_option->count() + o.ascans_option->count() + o.bscans_option->count() > 0;
  Input opened;
  if (is_hdf5_file(input)) {
    if (dimensions_given) {
      throw ioct::ConfigError("samples/ascans/bscans", input,
                              "a ring recording gives its dimensions; leave them out");
    }
    auto volume = std::make_unique<RingRecordingVolume>(input, o.volume_index);
    if (o.group_option->count() == 0) settings.bscans_per_group = volume->bscans_per_group();
    if (o.bidirectional_option->count() == 0) settings.bidirectional = volume->reversed_lines();
    opened.ring_recording = volume.get();
    opened.source = std::move(volume);
  } else if (is_recording(input, dimensions_given)) {
    if (dimensions_given) {
      throw ioct::ConfigError("samples/ascans/bscans", input,
                              "a recording's metadata gives its dimensions; leave them out");
    }
    auto volume = std::make_unique<RecordingVolume>(input, o.volume_index);
    const RecordingProcessingHints hints = volume->processing_hints();
    if (o.group_option->count() == 0) settings.bscans_per_group = hints.bscans_per_group;
    if (o.bidirectional_option->count() == 0) settings.bidirectional = hints.bidirectional;
    if (o.c2_option->count() == 0) settings.processing.dispersion.c2 = hints.dispersion_c2;
    if (o.c3_option->count() == 0) settings.processing.dispersion.c3 = hints.dispersion_c3;
    if (hints.resampling_coefficients != std::vector<double>{0.0, 1.0}) {
      opened.recording_calibration = hints.resampling_coefficients;
    }
    opened.recording = volume.get();
    opened.source = std::move(volume);
  } else {
    if (o.volume_option->count() > 0) {
      throw ioct::ConfigError("volume", std::to_string(o.volume_index),
                              "only a recording holds several volumes");
    }
    if (o.samples_option->count() == 0 || o.ascans_option->count() == 0 ||
        o.bscans_option->count() == 0) {
      throw ioct::ConfigError("samples/ascans/bscans", input,
                              "a raw u16 file needs --samples, --ascans and --bscans (no "
                              "recording metadata " +
                                  std::filesystem::path(input).replace_extension(".json").string() +
                                  " beside it)");
    }
    opened.source = std::make_unique<RawSpectraFile>(input, o.layout);
  }
  return opened;
}

// The resampling (the flags' calibration, else the recording's) and the filter after processing.
void choose_resampling_and_filter(Options& o, const std::vector<double>& recording_calibration) {
  std::optional<std::vector<double>> calibration;
  if (!o.poly.empty() || !o.calibration_file.empty()) {
    calibration =
        o.poly.empty() ? read_calibration_file(o.calibration_file) : parse_coefficients(o.poly);
  } else if (!recording_calibration.empty()) {
    calibration = recording_calibration;
  }
  o.settings.processing.resampling =
      choose_resampling(o.resample, calibration ? &*calibration : nullptr);
  if (o.filter != "none") {
    ioct::gpu::filters::VolumeFilterConfig config =
        ioct::gpu::filters::filter_by_name("filter", o.filter);
    config.gaussian_sigma = o.sigma;
    config.validate();
    o.settings.filter = config;
  }
}

// A recording acquired with faults makes a volume that may show them: the user is told which.
void warn_of_acquisition_faults(const Input& input, const ioct::Log& log) {
  const RecordingVolume* recording = input.recording;
  const RingRecordingVolume* ring_recording = input.ring_recording;
  if (recording != nullptr && recording->status_seen() != 0) {
    std::ostringstream line;
    line << recording->describe() << " was acquired with faults (status bits 0x" << std::hex
         << recording->status_seen() << std::dec
         << ": overrun 1, clock fault 2, missed triggers 4, timeout 8, device lost 16)";
    log.warning(line.str());
  }
  constexpr std::uint32_t kRingFaults = ioct::shm::kStatusMissedTriggers |
                                        ioct::shm::kStatusClockFault | ioct::shm::kStatusOverrun |
                                        ioct::shm::kStatusGalvoFault;
  if (ring_recording != nullptr && (ring_recording->status_seen() & kRingFaults) != 0) {
    std::ostringstream line;
    line << ring_recording->describe() << " was acquired with faults (ring status bits 0x"
         << std::hex << (ring_recording->status_seen() & kRingFaults) << std::dec
         << ": missed triggers 1, clock fault 2, overrun 4, galvo fault 16)";
    log.warning(line.str());
  }
}

// The NRRD volume and, when asked, the centre B-scan as PNG: both or neither.
void write_outputs(const Options& o, const RawProcessingResult& result,
                   const NrrdMetadata& metadata, std::uint32_t bscans) {
  const std::string& output = o.output;
  const std::string& png = o.png;
  // Everything is written before anything is committed: on any failure no output is left.
  ioct::AtomicFile volume_file(output);
  write_nrrd(volume_file.stream(), result.volume, metadata);
  if (!png.empty()) write_png_gray8(png, bscan_image(result.volume, bscans / 2));
  try {
    volume_file.commit();
  } catch (...) {
    if (!png.empty()) std::filesystem::remove(png);
    throw;
  }
  std::cout << "volume: " << output << " (" << result.volume.depth() << " x "
            << result.volume.ascans() << " x " << result.volume.bscans()
            << " depth x A-scans x B-scans, processed on " << result.processor_backend
            << (result.filter_backend.empty() ? "" : ", filtered on " + result.filter_backend)
            << ")\n";
  if (!png.empty()) std::cout << "bscan:  " << png << "\n";
}

// The command's work: settings, the input, processing and the outputs.
int process(Options& o) {
  const ioct::Log log("ioct-process");
  parse_settings(o, log);
  // The source first: a recording's metadata supplies what the options leave out.
  const Input input = open_input(o);
  choose_resampling_and_filter(o, input.recording_calibration);
  NrrdMetadata metadata;
  if (!o.spacing.empty()) {
    metadata.spacings = parse_spacings(o.spacing);
    metadata.unit = "mm";
  }

  const std::uint32_t bscans = input.source->layout().bscans;
  ProgressBar progress(stderr, "ioct-process", "B-scans", bscans,
                       ProgressBar::stderr_is_terminal());
  const RawProcessingResult result = process_raw_file(*input.source, o.settings, &progress);
  warn_of_acquisition_faults(input, log);
  metadata.content = "OCT volume from " + input.source->describe();
  metadata.key_values = {
      {"ioct_backend", result.processor_backend},
      {"ioct_db_range", std::to_string(o.settings.processing.scale.db_min) + " " +
                            std::to_string(o.settings.processing.scale.db_max)},
      {"ioct_filter", o.settings.filter
                          ? std::string(ioct::gpu::filters::filter_name(*o.settings.filter))
                          : std::string("none")}};
  write_outputs(o, result, metadata, bscans);
  return EXIT_SUCCESS;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{
      "ioct-process: raw u16 spectra from a file -> u8 volume (NRRD) through the ioct processing "
      "chain"};
  add_options(app, options);
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;
  return ioct::run_command("ioct-process", [&]() -> int { return process(options); });
}
