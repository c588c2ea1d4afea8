// ioct-sim-record: simulated raw groups and their ground truth, written as a raw recording
// (docs/recording-format.md) that ioct's tools and the replay digitizer read back.
//
//   ioct-sim-record --out run1 --groups 20 --preset retina --tool forceps:x=0.1,depth=0.4
//
// Exit status: 0 written; 2 a bad option or configuration (the message names it); 1 a file that
// cannot be written.
#include <time.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/recording/recording_writer.hpp"
#include "ioct/scan/scan_builder.hpp"
#include "ioct/scan/scan_infeasible.hpp"
#include "ioct/sim/instrument_spec.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/sim/simulated_galvo_output.hpp"
#include "ioct/sim/simulation_metadata.hpp"

namespace {

using namespace ioct;

struct FaultWindow {
  sim::Fault fault;
  std::uint64_t first_group;
  std::uint64_t last_group;
};

// The values the flags fill.
struct Options {
  std::string out;
  std::uint64_t groups = 10;
  std::uint32_t samples = 1376;
  std::uint32_t ascans = 512;
  std::uint32_t flyback = 26;
  std::uint32_t bscans_per_group = 16;
  std::uint32_t bscans_per_volume = 128;
  double rate = 100'000.0;
  std::uint32_t bits = 12;
  std::uint32_t timeout_ms = 500;
  std::string clock = "k-clock";
  std::string preset = "retina";
  std::uint64_t seed = 1;
  double c2 = 0.0;
  double c3 = 0.0;
  double rolloff_mm = 3.9;
  bool macular_hole = false;
  bool membrane = false;
  bool disc = false;
  std::vector<std::string> tools;
  bool galvo = false;
  bool bidirectional = false;
  std::uint32_t lead = 0;
  double natural_hz = 2000.0;
  double damping = 0.7;
  std::vector<std::string> faults;
  bool overwrite = false;
};

[[noreturn]] void bad(const std::string& key, const std::string& value,
                      const std::string& allowed) {
  throw ConfigError(key, value, allowed);
}

double number(const std::string& key, const std::string& text) {
  try {
    std::size_t used = 0;
    const double value = std::stod(text, &used);
    if (used == text.size()) return value;
  } catch (const std::exception&) {
  }
  bad(key, "'" + text + "'", "must be a number");
}

// "k_clock_dropout@3-5" or "usb_disconnect@7"
FaultWindow parse_fault(const std::string& spec) {
  const std::size_t at = spec.find('@');
  const auto fault = sim::parse_fault(spec.substr(0, at));
  if (!fault) {
    bad("--fault", "'" + spec + "'",
        "must be NAME@GROUP or NAME@FIRST-LAST, NAME one of k_clock_dropout, digitizer_stall, "
        "usb_disconnect, galvo_driver_fault, galvo_stream_stall, trigger_loss, slow_consumer, "
        "laser_not_ready");
  }
  if (at == std::string::npos) bad("--fault", "'" + spec + "'", "needs @GROUP or @FIRST-LAST");
  const std::string range = spec.substr(at + 1);
  const std::size_t dash = range.find('-');
  const double first = number("--fault", range.substr(0, dash));
  const double last = dash == std::string::npos ? first : number("--fault", range.substr(dash + 1));
  if (first < 0 || last < first) bad("--fault", "'" + spec + "'", "FIRST <= LAST, both >= 0");
  return {*fault, static_cast<std::uint64_t>(first), static_cast<std::uint64_t>(last)};
}

double cpu_seconds() {
  return 1e-9 * static_cast<double>(clock_ns(CLOCK_PROCESS_CPUTIME_ID));
}

// The digitizer's geometry and clock as the flags give them, checked.
hal::DigitizerConfig digitizer_geometry(const Options& o) {
  hal::DigitizerConfig geometry;
  geometry.samples_per_ascan = o.samples;
  geometry.ascans_per_bscan = o.ascans;
  geometry.flyback_sweeps = o.flyback;
  geometry.bscans_per_group = o.bscans_per_group;
  geometry.ascan_rate_hz = o.rate;
  geometry.sample_bits = o.bits;
  geometry.timeout_ms = o.timeout_ms;
  if (o.clock == "k-clock") {
    geometry.clock_source = hal::ClockSource::external_k_clock;
  } else if (o.clock == "internal") {
    geometry.clock_source = hal::ClockSource::internal;
  } else {
    bad("--clock", "'" + o.clock + "'", "must be k-clock or internal");
  }
  geometry.validate();
  return geometry;
}

// The simulated sample, instruments, scan and mirrors as the flags give them; the caller
// validates it after reading the fault windows, whose errors come first.
sim::SimulationConfig simulation_config(const Options& o) {
  sim::SimulationConfig s;
  if (o.preset == "retina") {
    s.preset = sim::SamplePreset::retina;
  } else if (o.preset == "anterior") {
    s.preset = sim::SamplePreset::anterior_segment;
  } else if (o.preset == "mirror") {
    s.preset = sim::SamplePreset::mirror;
  } else {
    bad("--preset", "'" + o.preset + "'", "must be retina, anterior or mirror");
  }
  s.seed = o.seed;
  s.interferometer.dispersion_c2 = o.c2;
  s.interferometer.dispersion_c3 = o.c3;
  s.source.rolloff_6db_depth_mm = o.rolloff_mm;
  s.retina.macular_hole.enabled = o.macular_hole;
  s.retina.membrane.enabled = o.membrane;
  s.retina.disc.enabled = o.disc;
  for (std::size_t i = 0; i < o.tools.size(); ++i)
    s.instruments.push_back(
        sim::parse_instrument_spec(o.tools[i], "--tool[" + std::to_string(i) + "]"));
  s.scan.ascans_per_bscan = o.ascans;
  s.scan.bscans_per_volume = o.bscans_per_volume;
  s.bench.mirrors.natural_hz = o.natural_hz;
  s.bench.mirrors.damping = o.damping;
  return s;
}

// Group `index` as the recording describes it: the times of its first and last sweeps are their
// sweep counters at the nominal sweep period.
recording::RecordedGroupInfo recorded_group_info(std::uint64_t index, const hal::GroupInfo& info,
                                                 const hal::DigitizerConfig& geometry) {
  const double period_ns = geometry.sweep_period_ns();
  return {index,
          info.first_sweep_counter,
          info.missed_sweeps,
          info.status,
          static_cast<std::uint64_t>(static_cast<double>(info.first_sweep_counter) * period_ns),
          static_cast<std::uint64_t>(
              static_cast<double>(info.first_sweep_counter + geometry.sweeps_per_group() - 1) *
              period_ns)};
}

// What was written, how large and how fast, and the recording's three files.
void report(const Options& o, const recording::RecordingMetadata& metadata,
            const recording::RecordingWriter& writer, double seconds) {
  const double mib = static_cast<double>(o.groups) *
                     static_cast<double>(recording::group_stride_bytes(metadata.geometry)) /
                     (1024.0 * 1024.0);
  std::fprintf(stderr,
               "ioct-sim-record: %llu groups (%.1f MiB) of %u samples x %u A-scans x %u B-scans, "
               "%s, seed %llu, %.1f ms CPU per group\n  %s\n  %s\n  %s\n",
               static_cast<unsigned long long>(o.groups), mib, o.samples, o.ascans,
               o.bscans_per_group, o.preset.c_str(), static_cast<unsigned long long>(o.seed),
               o.groups > 0 ? 1e3 * seconds / static_cast<double>(o.groups) : 0.0,
               writer.json_path().c_str(), writer.raw_path().c_str(), writer.truth_path().c_str());
}

// The scan a driven galvo follows, planned as ioct-rt plans it (within the default galvo limits)
// over ioct-rt's default field; `field`, where the ideal beam and the truth place A-scans, is set
// to the same field. A scan the mirrors cannot follow is refused in this command's own terms.
scan::ScanPattern plan_galvo_scan(const Options& o, const hal::DigitizerConfig& geometry,
                                  hal::RasterScan& field) {
  field.extent_x = field.extent_y = static_cast<float>(scan::ScanSpec::kDefaultExtent);
  const auto kind = o.bidirectional ? scan::ScanKind::bidirectional : scan::ScanKind::raster;
  try {
    return scan::plan_raster(field, geometry, kind, scan::GalvoLimits{});
  } catch (const scan::ScanInfeasible& e) {
    throw ConfigError(o.bidirectional ? "--bidirectional" : "--galvo", "true",
                      std::string(e.what()) +
                          " (the driven galvo's scan is planned as ioct-rt plans it, over a field "
                          "of +-" +
                          format_value(scan::ScanSpec::kDefaultExtent) +
                          " within the default galvo limits: give more --flyback sweeps, a lower "
                          "--rate or more --ascans)");
  }
}

// The command's work: the simulated acquisition of the groups, written as a recording.
int record(const Options& o) {
  const hal::DigitizerConfig geometry = digitizer_geometry(o);
  sim::SimulationConfig s = simulation_config(o);
  std::vector<FaultWindow> windows;
  for (const std::string& spec : o.faults) windows.push_back(parse_fault(spec));
  s.validate();

  const bool driven = o.galvo || o.bidirectional;
  scan::ScanPattern pattern;  // empty unless a galvo is driven
  if (driven) pattern = plan_galvo_scan(o, geometry, s.scan);
  auto bench = std::make_shared<sim::SimulatedBench>(s.bench);
  std::unique_ptr<sim::SimulatedGalvoOutput> galvo;
  if (driven) galvo = std::make_unique<sim::SimulatedGalvoOutput>(bench);
  sim::SimulatedDigitizer digitizer(s, bench);
  digitizer.prepare(geometry);

  std::uint64_t sweeps_written = 0;
  std::vector<hal::GalvoSample> samples;
  const auto top_up = [&] {
    // Keep two groups of commands queued ahead of the beam.
    const hal::GalvoStatus status = galvo->status();
    const std::uint64_t want = 2 * geometry.sweeps_per_group();
    if (status.fifo_fill >= want) return;
    samples.resize(want - status.fifo_fill);
    pattern.fill(sweeps_written, samples);
    sweeps_written += galvo->write(samples);
  };
  if (galvo) {
    hal::GalvoOutputConfig output;
    output.sample_rate_hz = o.rate;
    output.fifo_capacity = static_cast<std::uint32_t>(4 * geometry.sweeps_per_group());
    output.lead_samples = o.lead;
    galvo->prepare(output);
    top_up();
    galvo->start();
  }

  recording::RecordingMetadata metadata = sim::recording_metadata(digitizer);
  metadata.producer = "ioct-sim-record " IOCT_VERSION;
  metadata.scan.bidirectional = o.bidirectional;
  if (galvo) metadata.acquisition["galvo"] = {{"lead_samples", o.lead}, {"driven", true}};
  recording::RecordingWriter writer(o.out, metadata, {o.overwrite});

  std::vector<std::uint16_t> group(geometry.samples_per_group());
  digitizer.start();
  const double started = cpu_seconds();
  for (std::uint64_t g = 0; g < o.groups; ++g) {
    for (const FaultWindow& w : windows) {
      bench->faults().set(w.fault, g >= w.first_group && g <= w.last_group);
    }
    if (galvo) top_up();
    hal::GroupInfo info;
    digitizer.acquire_group(group, info);
    writer.append(group, recorded_group_info(g, info, geometry), &digitizer.last_group_truth());
  }
  const double seconds = cpu_seconds() - started;
  writer.close();
  report(o, metadata, writer, seconds);
  return 0;
}

// The command line: the recording, the digitizer, the simulated sample and scan, the faults.
void add_options(CLI::App& app, Options& o) {
  app.add_option("--out", o.out, "recording to write: STEM (STEM.json, STEM.raw, STEM.truth)")
      ->required();
  app.add_option("--groups", o.groups, "groups to record")->capture_default_str();
  app.add_option("--samples", o.samples, "samples per A-scan")->capture_default_str();
  app.add_option("--ascans", o.ascans, "A-scans per B-scan")->capture_default_str();
  app.add_option("--flyback", o.flyback, "flyback sweeps per B-scan")->capture_default_str();
  app.add_option("--bscans-per-group", o.bscans_per_group)->capture_default_str();
  app.add_option("--bscans-per-volume", o.bscans_per_volume)->capture_default_str();
  app.add_option("--rate", o.rate, "A-scan rate, Hz")->capture_default_str();
  app.add_option("--bits", o.bits, "ADC bits")->capture_default_str();
  app.add_option("--timeout-ms", o.timeout_ms, "digitizer stall timeout")->capture_default_str();
  app.add_option("--clock", o.clock, "k-clock (k-linear samples) or internal (linear in lambda)")
      ->capture_default_str();
  app.add_option("--preset", o.preset, "retina, anterior or mirror")->capture_default_str();
  app.add_option("--seed", o.seed, "same seed, same bytes")->capture_default_str();
  app.add_option("--c2", o.c2, "dispersion mismatch, rad of quadratic phase at the sweep's ends");
  app.add_option("--c3", o.c3, "dispersion mismatch, rad of cubic phase at the sweep's ends");
  app.add_option("--rolloff-mm", o.rolloff_mm, "depth of -6 dB sensitivity (0: none)")
      ->capture_default_str();
  app.add_flag("--macular-hole", o.macular_hole, "a full-thickness macular hole at the fovea");
  app.add_flag("--membrane", o.membrane, "an epiretinal membrane");
  app.add_flag("--disc", o.disc, "the optic disc with its cup, at the nasal edge");
  app.add_option("--tool", o.tools,
                 "instrument KIND[:name=value,...], KIND forceps|needle|scraper; names x, y "
                 "(scan units), depth (share of the axis), yaw, pitch, open (deg), vx, vy "
                 "(scan units/s), vdepth, tremor, tremor-depth, tremor-hz, jaw-cycle, jaw-hz; "
                 "repeatable");
  app.add_flag("--galvo", o.galvo, "drive the beam through a simulated galvo with mirror dynamics");
  app.add_flag("--bidirectional", o.bidirectional, "bidirectional raster (implies --galvo)");
  app.add_option("--lead", o.lead, "galvo lead compensation, samples")->capture_default_str();
  app.add_option("--natural-hz", o.natural_hz, "galvo natural frequency")->capture_default_str();
  app.add_option("--damping", o.damping, "galvo damping ratio")->capture_default_str();
  app.add_option("--fault", o.faults,
                 "NAME@GROUP or NAME@FIRST-LAST: inject a fault during those groups; repeatable");
  app.add_flag("--overwrite", o.overwrite, "replace an existing recording of the same name");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ioct-sim-record: simulated raw groups and their ground truth into a recording "
      "(STEM.json, STEM.raw, STEM.truth; see docs/recording-format.md)."};
  Options options;
  add_options(app, options);
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;
  return ioct::run_command("ioct-sim-record", [&]() -> int { return record(options); });
}
