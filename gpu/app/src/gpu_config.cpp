#include "gpu_config.hpp"

#include <algorithm>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/filters/filter_config.hpp"
#include "ioct/gpu/processing/resampling.hpp"
#include "ioct/gpu/render/render_config.hpp"

namespace ioct::gpu {
namespace {

// A key kept in an enum member, read and written through the library's own names for it: the
// getter and the setter, two arguments (so not one parenthesised expression).
// NOLINTNEXTLINE(bugprone-macro-parentheses)
#define IOCT_ENUM(expr, parse)                                       \
  [](const GpuConfig& c) { return std::string(to_string(c.expr)); }, \
      [](GpuConfig& c, const std::string& v) { c.expr = parse(v); }

void add_ring_keys(config::KeyTable<GpuConfig>& k) {
  k.text("ring.name", IOCT_MEMBER(live.ring_name),
         "the ring ioct-rt fills: a POSIX shm name without '/', or an absolute path", "--ring")
      .real_in("ring.wait_s", IOCT_MEMBER(live.wait_s), 0.0, 1e6,
               "seconds to wait for the ring to appear", "--wait")
      .real_in("ring.spin_window_s", IOCT_MEMBER(live.spin_window_s), 0.0, 0.1,
               "seconds the live loop and the stages' thread (the next group) and the frames' "
               "encoding thread (the next frame) stay awake, polling, on each side of when it is "
               "due, so waking a sleeping thread is not in its latency; asleep once 4 periods "
               "passed without one; only where a GPU does that work (on a CPU they sleep); 0: "
               "sleep between polls only",
               "--spin-window");
}

void add_output_keys(config::KeyTable<GpuConfig>& k) {
  k.text("output.dir", IOCT_MEMBER(live.out_dir),
         "folder for bscan.png, enface.png, render.png and summary.json", "--out")
      .choice_of("output.enface", {"mean", "max"}, IOCT_ENUM(live.enface, parse_enface_projection),
                 "en face projection of the volume", "--enface");
}

void add_status_keys(config::KeyTable<GpuConfig>& k) {
  k.real_in("status.interval_s", IOCT_MEMBER(live.status_interval_s), 0.0, 1e6,
            "seconds between status lines on stderr; 0: none", "--status-interval");
}

void add_processing_keys(config::KeyTable<GpuConfig>& k) {
  k.choice("processing.backend", IOCT_MEMBER(backend), {"auto", "cpu", "cuda"},
           "where processing and the stages run; auto: CUDA when a usable GPU is present",
           "--backend")
      .integer("processing.threads", IOCT_MEMBER(live.processing.threads), 1, 16,
               "CPU threads processing a group's B-scans", "--threads")
      .integer("processing.repeats", IOCT_MEMBER(live.processing.repeats_per_position), 1, 16,
               "B-scans acquired per position, averaged into one", "--repeats")
      .real_in("processing.db_min", IOCT_MEMBER(live.processing.scale.db_min), -200.0, 300.0,
               "dB shown as black (20 log10 of the fringe amplitude in ADC counts)", "--db-min")
      .real_in("processing.db_max", IOCT_MEMBER(live.processing.scale.db_max), -200.0, 300.0,
               "dB shown as white (at least 1 dB above db_min)", "--db-max")
      .choice_of("processing.background", {"rolling", "none"},
                 IOCT_ENUM(live.processing.background.mode, parse_background_mode),
                 "background removal", "--background")
      .integer("processing.background_groups", IOCT_MEMBER(live.processing.background.groups), 1,
               64, "groups in the rolling mean background, the current one included",
               "--background-groups")
      .choice("processing.resample", IOCT_MEMBER(resample), {"auto", "none", "linear", "cubic"},
              "lambda to k resampling; auto: cubic with resample_poly, none without (k-clock)",
              "--resample")
      .text("processing.resample_poly", IOCT_MEMBER(resample_poly),
            "calibration c0,c1,...: output sample j is read at raw position (N-1) sum c_i "
            "(j/(N-1))^i; empty: none",
            "--resample-poly")
      .choice_of("processing.window", {"hann", "rectangular"},
                 IOCT_ENUM(live.processing.window.kind, parse_window_kind), "spectral window",
                 "--window")
      .real_in("processing.dispersion_c2", IOCT_MEMBER(live.processing.dispersion.c2), -10000.0,
               10000.0, "quadratic dispersion phase, rad at the sweep's ends (ioct-dispersion)",
               "--dispersion-c2")
      .real_in("processing.dispersion_c3", IOCT_MEMBER(live.processing.dispersion.c3), -10000.0,
               10000.0, "cubic dispersion phase, rad", "--dispersion-c3")
      .choice_of("processing.fft_rigor", {"estimate", "measure", "patient"},
                 IOCT_ENUM(live.processing.fft.rigor, parse_fft_rigor), "FFTW planning",
                 "--fft-rigor")
      .text("processing.fft_wisdom", IOCT_MEMBER(live.processing.fft.wisdom_path),
            "FFTW wisdom file, read before planning and updated after; empty: none",
            "--fft-wisdom");
}

void add_stages_keys(config::KeyTable<GpuConfig>& k) {
  k.boolean("stages.enabled", IOCT_MEMBER(stages_enabled),
            "filter, segment and render the live volume (false: only process)", "--no-stages")
      .integer("stages.threads", IOCT_MEMBER(stages.cpu_threads), 1, 64,
               "threads of each CPU stage (filters, segmentation, rendering)", "--stage-threads")
      .choice("stages.filter", IOCT_MEMBER(filter),
              {"auto", "median-gauss", "median-bscan", "none"},
              "the live volume's filter: auto (median-gauss for the segmentation and Viehland's "
              "modes; the layer-aware, la-mip and axial-colorization modes render a second "
              "volume, median-bscan), or one filter for everything: median-gauss (3x3x3 median + "
              "5x5 Gaussian, Viehland 2016), median-bscan (3x3 median per B-scan, Weiss 2019) or "
              "none",
              "--filter")
      .real_in("stages.cpu_render_interval_s", IOCT_MEMBER(stages.cpu_render_interval_s), 0.0,
               3600.0, "seconds between live renders on the CPU (the GPU renders every group)",
               "--cpu-render-interval")
      .real_in("stages.frame_rate_hz", IOCT_MEMBER(stages.frame_rate_hz), 0.1, 1000.0,
               "renders per second of a moving view at most (auto-rotation, interaction)",
               "--frame-rate")
      .real_in("stages.cpu_moving_scale", IOCT_MEMBER(stages.cpu_moving_scale), 0.05, 1.0,
               "CPU renderer: a moving view's frame size as a fraction of the output (full size "
               "once it stops)",
               "--cpu-moving-scale")
      .text_list("stages.final_modes", IOCT_MEMBER(final_modes),
                 "render modes also written when the run ends, at the live view, each as "
                 "render-MODE.png (render.mode's names); empty: render.png alone. On the CPU "
                 "each takes seconds of the stop",
                 "--final-mode");
}

void add_render_keys(config::KeyTable<GpuConfig>& k) {
  k.choice_of(
       "render.mode",
       {"basic", "enhanced", "layer-aware", "axial-colorization", "la-mip", "bscan", "en-face"},
       IOCT_ENUM(stages.render.mode, render::parse_render_mode),
       "the live view's render mode at start", "--render-mode")
      .integer("render.width", IOCT_MEMBER(stages.render.view.output_width), 1, 8192,
               "live view width, px", "--render-width")
      .integer("render.height", IOCT_MEMBER(stages.render.view.output_height), 1, 8192,
               "live view height, px", "--render-height");

  // Ranges: segmentation::VolumeSampling::validate() and InstrumentConfig::validate(), which
  // name these keys.
}

void add_sampling_keys(config::KeyTable<GpuConfig>& k) {
  k.real("sampling.axial_um_per_px", IOCT_MEMBER(stages.sampling.axial_um_per_px),
         "depth pixel size, um (0.1 to 1000)", "--axial-um")
      .real("sampling.ascan_spacing_um", IOCT_MEMBER(stages.sampling.ascan_spacing_um),
            "distance between neighbouring A-scans, um (0.1 to 1000)", "--ascan-spacing-um")
      .real("sampling.bscan_spacing_um", IOCT_MEMBER(stages.sampling.bscan_spacing_um),
            "distance between neighbouring B-scans, um (0.1 to 1000)", "--bscan-spacing-um");
}

void add_instruments_keys(config::KeyTable<GpuConfig>& k) {
  k.boolean("instruments.enabled", IOCT_MEMBER(stages.instruments.enabled),
            "find instruments each pass: tip position, tip-to-ILM/RPE distances", "--instruments")
      .real("instruments.warn_rpe_um", IOCT_MEMBER(stages.instruments.warn_rpe_um),
            "warn when a tip is within this distance of the RPE, um (0 to 10000)",
            "--instruments-warn-rpe-um");
}

void add_view_keys(config::KeyTable<GpuConfig>& k) {
  k.text("view.frames", IOCT_MEMBER(frames),
         "frame ring for ioct-view (shm name or absolute path); `<ring>.frames`: the ring's "
         "name + .frames; none: no frames",
         "--frames")
      .text("view.group", IOCT_MEMBER(view_group),
            "group of the frame ring and the view socket (ioct-view's); empty: this process's",
            "--view-group")
      .text("view.socket", IOCT_MEMBER(view_socket),
            "Unix socket for ioct-view's render-parameter requests (JSON lines); empty: none",
            "--view-socket")
      .text("view.snapshot_dir", IOCT_MEMBER(snapshot_dir),
            "folder the view socket's snapshots go to; `<out>/snapshots`: under output.dir",
            "--snapshot-dir");
}

config::KeyTable<GpuConfig> make_keys() {
  config::KeyTable<GpuConfig> k;
  add_ring_keys(k);
  add_output_keys(k);
  add_status_keys(k);
  add_processing_keys(k);
  add_stages_keys(k);
  add_render_keys(k);
  add_sampling_keys(k);
  add_instruments_keys(k);
  add_view_keys(k);
  return k;
}

#undef IOCT_ENUM

// stages.final_modes as modes; an unknown or repeated name is told under its index.
std::vector<render::RenderMode> final_render_modes(const std::vector<std::string>& names) {
  std::vector<render::RenderMode> modes;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string key = "stages.final_modes[" + std::to_string(i) + "]";
    const render::RenderMode mode = render::parse_render_mode(names[i], key);
    if (std::ranges::find(modes, mode) != modes.end()) {
      throw ConfigError(key, "'" + names[i] + "'", "is named twice");
    }
    modes.push_back(mode);
  }
  return modes;
}

GpuSetup resolve(const GpuConfig& c, const RunLimits& limits) {
  gpu_keys().check_ranges(c);
  GpuSetup setup;
  setup.config = c;
  LiveConfig& live = setup.live;
  live = c.live;
  live.run_s = limits.run_s;
  live.exit_when_producer_gone = limits.exit_when_producer_gone;
  live.backend = parse_backend(c.backend);
  std::optional<std::vector<double>> calibration;
  if (!c.resample_poly.empty()) calibration = parse_coefficients(c.resample_poly);
  live.processing.resampling = choose_resampling(c.resample == "auto" ? "" : c.resample,
                                                 calibration ? &*calibration : nullptr);
  live.validate();
  if (c.stages_enabled) {
    live::VolumeStagesConfig& stages = setup.stages.emplace(c.stages);
    stages.backend = live.backend;
    const double sigma = stages.filter.gaussian_sigma;
    stages.render_filter_by_mode = c.filter == "auto";
    stages.filter =
        filters::filter_by_name("stages.filter", c.filter == "auto" ? "median-gauss" : c.filter);
    stages.filter.gaussian_sigma = sigma;
    stages.render.spacing = {stages.sampling.ascan_spacing_um, stages.sampling.bscan_spacing_um,
                             stages.sampling.axial_um_per_px};
    stages.live_image = live.out_dir / "render.png";
    stages.final_modes = final_render_modes(c.final_modes);
    const std::string frames = c.frames == "<ring>.frames" ? live.ring_name + ".frames" : c.frames;
    stages.frame_ring = frames == "none" ? "" : frames;
    stages.frame_group = c.view_group;
    stages.spin_window_s = live.spin_window_s;
    stages.validate();
  }
  if (!c.view_socket.empty()) {
    if (!c.stages_enabled) {
      throw ConfigError("view.socket", "\"" + c.view_socket + "\"",
                        "needs the live stages (stages.enabled = true, not --no-stages)");
    }
    live::ViewSocketConfig& socket = setup.socket.emplace();
    socket.path = c.view_socket;
    socket.group = c.view_group;
    socket.snapshot_dir = c.snapshot_dir == "<out>/snapshots"
                              ? live.out_dir / "snapshots"
                              : std::filesystem::path(c.snapshot_dir);
  }
  return setup;
}

// The names the components' own validate() give keys that the file calls otherwise (they serve the
// offline commands' flags too): an error of theirs is told under the file's key.
constexpr std::pair<std::string_view, std::string_view> kComponentKeys[] = {
    {"ring", "ring.name"},
    {"out", "output.dir"},
    {"db_min", "processing.db_min"},
    {"db_max", "processing.db_max"},
    {"resample", "processing.resample"},
    {"resampling", "processing.resample"},
    {"resampling_coefficients", "processing.resample_poly"},
    {"fft_wisdom", "processing.fft_wisdom"},
    {"stages.frames", "view.frames"},
};

ConfigError in_file_terms(const ConfigError& e) {
  const std::string_view key = std::string_view(e.key()).substr(0, e.key().find('['));
  for (const auto& [component, declared] : kComponentKeys) {
    if (key != component) continue;
    const std::string what = e.what();
    const std::string said = e.key() + " = " + e.value() + ": ";
    return ConfigError(std::string(declared), e.value(),
                       what.rfind(said, 0) == 0 ? what.substr(said.size()) : what);
  }
  return e;
}

}  // namespace

const config::KeyTable<GpuConfig>& gpu_keys() {
  static const config::KeyTable<GpuConfig> keys = make_keys();
  return keys;
}

GpuSetup make_gpu_setup(const std::string& file, const config::Overrides& overrides,
                        const RunLimits& limits) {
  GpuConfig c;
  config::KeyPositions positions;
  if (!file.empty()) gpu_keys().read_file(file, c, &positions);
  gpu_keys().apply(overrides, c);
  try {
    return resolve(c, limits);
  } catch (const ConfigError& component_error) {
    const ConfigError e = in_file_terms(component_error);
    // Placed in the file when the key came from it and no flag overrode it (a list's element,
    // key[i], at its list).
    const std::string key = e.key().substr(0, e.key().find('['));
    const auto at = positions.find(key);
    if (at == positions.end() || overrides.contains(key)) throw e;
    throw config::ConfigFileError(file, at->second, e.what());
  }
}

}  // namespace ioct::gpu
