// ioct-dispersion: estimates the dispersion correction (c2, c3) of a raw group, read from a file
// or live from the ring, by maximising the sharpness of its tissue, then checks it on the volume
// the chain makes (dispersion_estimator.hpp). Prints both sharpness figures and the ioct-gpu
// options that apply the result (none when the estimate lost the check).
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ioct/common/atomic_file.hpp"
#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/gpu/offline/calibration_file.hpp"
#include "ioct/gpu/processing/dispersion_estimator.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_reader.hpp"

namespace {

using namespace ioct::gpu;
namespace shm = ioct::shm;

struct Group {
  shm::RingGeometry geometry;
  shm::SlotHeader header{};
  std::vector<std::uint16_t> spectra;
  std::string source;
};

struct FileOptions {
  std::string path;
  std::uint32_t samples = 0;
  std::uint32_t ascans_per_bscan = 512;
  std::uint32_t active_begin = 0;
  std::uint32_t active_end = 0;  // 0: all
};

// A raw group file: little-endian u16 samples [bscan][record][sample], as a ring slot holds them.
Group read_group_file(const FileOptions& o) {
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(o.path, ec);
  if (ec) throw std::runtime_error("cannot read group file '" + o.path + "': " + ec.message());
  ioct::require_integer_in_range("samples", o.samples, 8, 1u << 16);
  ioct::require_integer_in_range("ascans_per_bscan", o.ascans_per_bscan, 1, 1u << 16);
  const std::uint64_t bscan_bytes = std::uint64_t{o.samples} * o.ascans_per_bscan * 2;
  if (bytes == 0 || bytes % bscan_bytes != 0 || bytes / bscan_bytes > shm::kMaxBscansPerGroup) {
    throw ioct::ConfigError(
        "group_file", "'" + o.path + "'",
        "must hold 1 to 64 whole B-scans of " + std::to_string(o.ascans_per_bscan) + " x " +
            std::to_string(o.samples) + " u16 samples (" + std::to_string(bscan_bytes) +
            " bytes each); it has " + std::to_string(bytes) + " bytes");
  }
  Group g;
  g.source = o.path;
  g.geometry.samples_per_ascan = o.samples;
  g.geometry.ascans_per_bscan = o.ascans_per_bscan;
  g.geometry.bscans_per_group = static_cast<std::uint32_t>(bytes / bscan_bytes);
  g.geometry.bscans_per_volume = g.geometry.bscans_per_group;
  g.spectra.resize(bytes / 2);
  std::ifstream in(o.path, std::ios::binary);
  if (!in.read(reinterpret_cast<char*>(g.spectra.data()), static_cast<std::streamsize>(bytes))) {
    throw std::runtime_error("cannot read group file '" + o.path + "'");
  }
  g.header.bscan_count = g.geometry.bscans_per_group;
  g.header.payload_bytes = bytes;
  g.header.active_ascan_begin = o.active_begin;
  g.header.active_ascan_end = o.active_end == 0 ? o.ascans_per_bscan : o.active_end;
  for (std::uint32_t b = 0; b < g.header.bscan_count; ++b) g.header.bscans[b].bscan_in_volume = b;
  return g;
}

// The next group published on `ring`, waiting up to `wait_s` for the ring and the group.
Group read_live_group(const std::string& ring, double wait_s) {
  const std::uint64_t deadline = ioct::monotonic_ns() + ioct::seconds_to_ns(wait_s);
  for (;;) {
    try {
      shm::RingReader reader = shm::RingReader::attach(ring, {"ioct-dispersion"});
      Group g;
      g.source = "ring '" + ring + "'";
      g.geometry = reader.geometry();
      g.spectra.resize((reader.layout().group_payload_bytes + 1) / 2);
      const std::span<std::byte> buffer(reinterpret_cast<std::byte*>(g.spectra.data()),
                                        reader.layout().group_payload_bytes);
      for (;;) {
        const shm::PollStatus status = reader.read_next(buffer, g.header);
        if (status == shm::PollStatus::ready) return g;
        if (status == shm::PollStatus::producer_gone) break;
        if (ioct::monotonic_ns() >= deadline) {
          throw std::runtime_error("no group arrived on ring '" + ring + "' within " +
                                   ioct::format_value(wait_s) + " s");
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    } catch (const shm::RingError& e) {
      if (e.code() != shm::RingErrc::not_found && e.code() != shm::RingErrc::not_ready &&
          e.code() != shm::RingErrc::producer_gone) {
        throw;
      }
      if (ioct::monotonic_ns() >= deadline) throw;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

void save_group(const Group& g, const std::string& path) {
  ioct::AtomicFile file(path);
  const std::size_t bytes = g.geometry.group_payload_bytes();
  if (std::fwrite(g.spectra.data(), 1, bytes, file.stream()) != bytes) {
    throw std::runtime_error("cannot write '" + path + "'");
  }
  file.commit();
}

// The check's processing before the flags: the rolling background over the one group there is.
OctProcessorConfig check_processing_defaults() {
  OctProcessorConfig processing;
  processing.background.groups = 1;
  return processing;
}

// The values the flags fill.
struct Options {
  FileOptions file;
  std::string ring;
  double wait_s = 5.0;
  std::string save_path;
  std::string json_path;
  OctProcessorConfig processing = check_processing_defaults();
  DispersionSearch search;
  std::string background = "rolling";
  std::string window = std::string(to_string(processing.window.kind));
  std::string resampling;  // empty: cubic with a calibration, else none (as ioct-process)
  std::string coefficients;
  std::string calibration_file;
  bool no_check = false;
};

// The command line: where the group comes from, how it is processed and how the search runs.
void add_options(CLI::App& app, Options& o) {
  app.option_defaults()->always_capture_default();
  auto* file_option = app.add_option("--group-file", o.file.path,
                                     "raw group: little-endian u16 [bscan][record][sample]");
  app.add_option("--samples", o.file.samples, "samples per A-scan in the group file");
  app.add_option("--ascans-per-bscan", o.file.ascans_per_bscan, "records per B-scan in the file");
  app.add_option("--active-begin", o.file.active_begin, "first active record of each B-scan");
  app.add_option("--active-end", o.file.active_end, "end of the active records; 0: all");
  auto* ring_option = app.add_option("--ring", o.ring, "read the next group from this ring");
  app.add_option("--wait", o.wait_s, "seconds to wait for the ring and a group");
  app.add_option("--save-group", o.save_path, "also save the group read from the ring to a file");
  app.add_option("--background", o.background,
                 "background removal: rolling (the group's mean) or none");
  app.add_option("--resample", o.resampling,
                 "lambda -> k resampling: none, linear or cubic (default: cubic when a "
                 "calibration is given, else none, as ioct-process)");
  auto* poly_option =
      app.add_option("--resample-poly", o.coefficients, "calibration c0,c1,... (see ioct-gpu)");
  auto* calibration_option = app.add_option("--calibration-file", o.calibration_file,
                                            "the calibration from a file (as ioct-process)");
  app.add_option("--window", o.window, "spectral window: hann or rectangular");
  app.add_option("--c2-limit", o.search.c2_limit, "search c2 in [-limit, limit] rad");
  app.add_option("--c3-limit", o.search.c3_limit, "search c3 in [-limit, limit] rad");
  app.add_option("--ascans", o.search.ascans, "brightest A-scans used for the metric");
  app.add_option("--dc-rows", o.search.dc_rows,
                 "rows next to zero delay left out of the metric; 0: samples / 64, at least 8");
  app.add_option("--fixed-coherence", o.search.fixed_coherence,
                 "phase coherence across A-scans above which a row is a fixed-pattern line");
  app.add_flag("--no-check", o.no_check,
               "skip processing the group at the estimate and at none to compare them");
  app.add_option("--db-min", o.processing.scale.db_min, "dB range of the check's processing");
  app.add_option("--db-max", o.processing.scale.db_max, "dB range of the check's processing");
  app.add_option("--json", o.json_path, "also write the result as JSON");
  file_option->excludes(ring_option);
  poly_option->excludes(calibration_option);
}

// The flags' words turned into the processing and the search, refused before any group is read.
void complete_settings(Options& o) {
  if (o.file.path.empty() == o.ring.empty()) {
    throw ioct::ConfigError("source", "''", "give exactly one of --group-file or --ring");
  }
  o.processing.background.mode = parse_background_mode(o.background);
  o.processing.window.kind = parse_window_kind(o.window);
  // The chain's resampling, chosen as ioct-process chooses it: an estimate made on spectra
  // resampled otherwise than the volume's compensates the difference, not the dispersion.
  std::optional<std::vector<double>> calibration;
  if (!o.coefficients.empty() || !o.calibration_file.empty()) {
    calibration = o.coefficients.empty()
                      ? ioct::gpu::offline::read_calibration_file(o.calibration_file)
                      : parse_coefficients(o.coefficients);
  }
  o.processing.resampling = choose_resampling(o.resampling, calibration ? &*calibration : nullptr);
  o.search.check_on_chain = !o.no_check;
  o.processing.scale.validate();
}

// The estimate in words, ending with the ioct-gpu options that apply it.
void print_estimate(const Group& group, const OctProcessorConfig& processing,
                    const DispersionEstimate& e) {
  std::printf("source: %s (%u x %u x %u samples)\n", group.source.c_str(), group.header.bscan_count,
              group.geometry.ascans_per_bscan, group.geometry.samples_per_ascan);
  std::printf("processing: resampling %s%s%s, window %s, background %s\n",
              std::string(to_string(processing.resampling.interpolation)).c_str(),
              processing.resampling.enabled() ? " " : "",
              processing.resampling.enabled()
                  ? format_coefficients(processing.resampling.coefficients).c_str()
                  : "",
              std::string(to_string(processing.window.kind)).c_str(),
              std::string(to_string(processing.background.mode)).c_str());
  std::printf(
      "search: c2 = %.3f rad, c3 = %.3f rad; metric %.5g (uncompensated %.5g) over the "
      "%u brightest A-scans, %u evaluations; rows left out: below %u (DC), %zu "
      "fixed-pattern\n",
      e.searched_c2, e.searched_c3, e.sharpness, e.sharpness_uncompensated, e.ascans_used,
      e.evaluations, e.dc_rows, e.fixed_pattern_rows.size());
  if (e.checked) {
    std::printf(
        "processed volume, standard sharpness: %.5g at the search's c2, c3; %.5g "
        "uncompensated\n",
        e.processed_sharpness, e.processed_sharpness_uncompensated);
  }
  std::printf("%s\n", describe_check(e).c_str());
  if (e.depth_dependent) {
    std::printf(
        "warning: the best c2 depends on depth (%.3f rad above row %u, %.3f below): "
        "the spectra are probably not linear in k as processed; check the calibration "
        "(--resample-poly, --calibration-file) before applying this estimate\n",
        e.c2_shallow, e.depth_split, e.c2_deep);
  }
  if (!processing.resampling.enabled()) {
    std::printf(
        "note: samples taken as linear in k (no resampling); for a lambda-linear sweep give "
        "the calibration the volume is processed with, or the estimate compensates the "
        "sampling instead of the dispersion\n");
  }
  std::printf("c2 = %.3f rad, c3 = %.3f rad\n", e.c2, e.c3);
  std::printf("ioct-gpu options: --dispersion-c2 %.3f --dispersion-c3 %.3f\n", e.c2, e.c3);
}

// The estimate and every figure behind it, for scripts (--json).
void write_estimate_json(const std::string& path, const Group& group,
                         const OctProcessorConfig& processing, const DispersionEstimate& e) {
  const nlohmann::json j = {
      {"source", group.source},
      {"c2", e.c2},
      {"c3", e.c3},
      {"searched_c2", e.searched_c2},
      {"searched_c3", e.searched_c3},
      {"rejected", e.rejected},
      {"resampling", to_string(processing.resampling.interpolation)},
      {"resampling_coefficients", processing.resampling.coefficients},
      {"checked", e.checked},
      {"check", describe_check(e)},
      {"sharpness", e.sharpness},
      {"sharpness_uncompensated", e.sharpness_uncompensated},
      {"processed_sharpness", e.processed_sharpness},
      {"processed_sharpness_uncompensated", e.processed_sharpness_uncompensated},
      {"dc_rows", e.dc_rows},
      {"depth_split", e.depth_split},
      {"c2_shallow", e.c2_shallow},
      {"c2_deep", e.c2_deep},
      {"depth_dependent", e.depth_dependent},
      {"fixed_pattern_rows", e.fixed_pattern_rows},
      {"ascans_used", e.ascans_used},
      {"evaluations", e.evaluations}};
  ioct::write_text_file_atomically(path, j.dump(2) + "\n");
}

// The command's work: settings, the group, the estimate and its report.
int estimate_dispersion(Options& o) {
  complete_settings(o);
  DispersionEstimator estimator(o.processing, o.search);
  const Group group = o.ring.empty() ? read_group_file(o.file) : read_live_group(o.ring, o.wait_s);
  if (!o.save_path.empty()) save_group(group, o.save_path);
  estimator.load(group.geometry, RawGroup{group.header, group.spectra});
  const DispersionEstimate e = estimator.estimate();
  print_estimate(group, o.processing, e);
  if (!o.json_path.empty()) write_estimate_json(o.json_path, group, o.processing, e);
  return EXIT_SUCCESS;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{
      "ioct-dispersion: estimates the dispersion correction c2, c3 of a raw group (a file or "
      "the next group on the ring) by maximising the sharpness of its A-scans"};
  add_options(app, options);
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;
  return ioct::run_command("ioct-dispersion",
                           [&]() -> int { return estimate_dispersion(options); });
}
