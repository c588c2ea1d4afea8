// ioct-gpu: reads raw B-scan groups from the ring, processes them into the live volume, filters,
// segments and renders it group by group, and writes the latest centre B-scan, en face
// projection, surfaces and renders as files.
#include <CLI/CLI.hpp>

#include <atomic>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/common/stop_signals.hpp"
#include "ioct/gpu/ingest/live_processor.hpp"
#include "ioct/gpu/live_stages/processing_view_control.hpp"
#include "ioct/gpu/live_stages/view_socket.hpp"
#include "ioct/gpu/live_stages/volume_stages.hpp"
#include "ioct/shm/ring_error.hpp"

namespace {

// Atomic: the stop signal may be handled on any thread (a lock-free atomic is signal-safe).
std::atomic<ioct::gpu::LiveProcessor*> g_processor{nullptr};

extern "C" void on_stop_signal(int) {
  if (ioct::gpu::LiveProcessor* p = g_processor.load()) p->request_stop();
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ioct::gpu;
  LiveConfig config;
  std::string backend = "auto";
  std::string out_dir = config.out_dir.string();
  std::string background = std::string(to_string(config.processing.background.mode));
  std::string window = std::string(to_string(config.processing.window.kind));
  std::string resampling;    // empty: cubic with a calibration, none without (choose_resampling)
  std::string coefficients;  // empty: no calibration
  std::string rigor = std::string(to_string(config.processing.fft.rigor));
  std::string enface = std::string(to_string(config.enface));

  CLI::App app{"ioct-gpu: OCT processing of the ring's raw spectra into volumes and PNG previews"};
  app.option_defaults()->always_capture_default();
  app.add_option("--ring", config.ring_name, "shared-memory ring to read");
  app.add_option("--out", out_dir, "directory for bscan.png, enface.png and summary.json");
  app.add_option("--backend", backend,
                 "processing backend: cpu, cuda, or auto (cuda when a usable GPU is present)");
  app.add_option("--db-min", config.processing.scale.db_min,
                 "dB shown as black (20 log10 of the fringe amplitude in ADC counts)");
  app.add_option("--db-max", config.processing.scale.db_max, "dB shown as white");
  app.add_option("--threads", config.processing.threads,
                 "threads processing a group's B-scans (1 to 16)");
  app.add_option("--wait", config.wait_s, "seconds to wait for the ring to appear");
  app.add_option("--seconds", config.run_s,
                 "seconds to run; 0: until SIGINT/SIGTERM (or the producer goes, with "
                 "--exit-when-producer-gone)");
  app.add_flag("--exit-when-producer-gone", config.exit_when_producer_gone,
               "finish when the producer closes the ring, instead of waiting for it to come back "
               "and reattaching (a service waits; a demo or a test finishes)");
  app.add_option("--status-interval", config.status_interval_s,
                 "seconds between status lines on stderr; 0: none");
  app.add_option("--background", background, "background removal: rolling or none");
  app.add_option("--background-groups", config.processing.background.groups,
                 "groups in the rolling mean background, the current one included (1 to 64)");
  app.add_option("--resample", resampling,
                 "lambda -> k resampling: none (k-clock), linear or cubic (default: cubic with "
                 "--resample-poly, none without)");
  app.add_option("--resample-poly", coefficients,
                 "calibration c0,c1,...: output sample j is read at raw position "
                 "(N-1) * sum c_i (j/(N-1))^i");
  app.add_option("--window", window, "spectral window: hann or rectangular");
  app.add_option("--dispersion-c2", config.processing.dispersion.c2,
                 "quadratic dispersion phase (rad at the sweep's ends); see ioct-dispersion");
  app.add_option("--dispersion-c3", config.processing.dispersion.c3,
                 "cubic dispersion phase (rad)");
  app.add_option("--repeats", config.processing.repeats_per_position,
                 "B-scans acquired per position, averaged into one (1 to 16)");
  app.add_option("--fft-rigor", rigor, "FFTW planning: estimate, measure or patient");
  app.add_option("--fft-wisdom", config.processing.fft.wisdom_path,
                 "FFTW wisdom file, read before planning and updated after");
  app.add_option("--enface", enface, "en face projection: mean or max");
  live::VolumeStagesConfig stages;
  bool no_stages = false;
  std::string render_mode = std::string(render::to_string(stages.render.mode));
  app.add_flag("--no-stages", no_stages,
               "only process: no filters, segmentation or rendering of the live volume");
  app.add_option("--stage-threads", stages.cpu_threads,
                 "threads of each CPU stage (filters, segmentation, rendering)");
  std::string filter = "median-gauss";
  app.add_option(
      "--filter", filter,
      "the live volume's filter (segmentation and every view use it): median-gauss "
      "(3x3x3 median + 5x5 Gaussian, Viehland 2016) or median-bscan (3x3 median per "
      "B-scan, Weiss 2019: keeps small superficial structure, for the layer-aware modes)");
  app.add_option("--render-mode", render_mode,
                 "live view: basic, enhanced, layer-aware, axial-colorization, la-mip, bscan or "
                 "en-face");
  app.add_option("--render-width", stages.render.view.output_width, "live view width, px");
  app.add_option("--render-height", stages.render.view.output_height, "live view height, px");
  app.add_option("--cpu-render-interval", stages.cpu_render_interval_s,
                 "seconds between live renders on the CPU (the GPU renders every new group)");
  std::string frames = "<ring>.frames";
  std::string view_socket;
  std::string snapshot_dir = "<out>/snapshots";
  app.add_option("--frames", frames,
                 "frame ring for ioct-view (shared-memory name); empty or 'none': no frames");
  std::string view_group;
  app.add_option("--view-group", view_group,
                 "group of the frame ring and the view socket (ioct-view's); default: this "
                 "process's");
  app.add_option("--view-socket", view_socket,
                 "Unix socket for render-parameter requests (JSON lines); empty: none");
  app.add_option("--snapshot-dir", snapshot_dir, "folder the view socket's snapshots go to");
  app.add_option("--frame-rate", stages.frame_rate_hz,
                 "renders per second of a moving view at most (auto-rotation, interaction)");
  app.add_option("--cpu-moving-scale", stages.cpu_moving_scale,
                 "CPU renderer: size of a moving view's frames, as a fraction of the output "
                 "(full size once it stops)");
  app.add_option("--axial-um", stages.sampling.axial_um_per_px, "depth pixel size, um");
  app.add_option("--ascan-spacing-um", stages.sampling.ascan_spacing_um,
                 "distance between neighbouring A-scans, um");
  app.add_option("--bscan-spacing-um", stages.sampling.bscan_spacing_um,
                 "distance between neighbouring B-scans, um");
  app.add_flag("--instruments", stages.instruments.enabled,
               "find instruments each pass: tip position, tip-to-ILM/RPE distances (the status "
               "line, summary.json, the view socket's \"instruments\" request)");
  app.add_option("--instruments-warn-rpe-um", stages.instruments.warn_rpe_um,
                 "warn when an instrument's tip is within this distance of the RPE, um");
  CLI11_PARSE(app, argc, argv);

  try {
    config.out_dir = out_dir;
    config.backend = parse_backend(backend);
    config.processing.background.mode = parse_background_mode(background);
    config.processing.window.kind = parse_window_kind(window);
    std::optional<std::vector<double>> calibration;
    if (!coefficients.empty()) calibration = parse_coefficients(coefficients);
    config.processing.resampling =
        choose_resampling(resampling, calibration ? &*calibration : nullptr);
    config.processing.fft.rigor = parse_fft_rigor(rigor);
    config.enface = parse_enface_projection(enface);
    LiveProcessor processor(config);
    if (config.backend == Backend::cuda) {
      (void)make_oct_processor(config.backend, config.processing);  // fail before waiting
    }
    // "auto" is resolved once the ring is attached (LiveProcessor), with one warning when it
    // falls back to the CPU.
    std::unique_ptr<live::VolumeStages> volume_stages;
    if (!no_stages) {
      stages.backend = config.backend;
      stages.render.mode = render::parse_render_mode(render_mode);
      const double sigma = stages.filter.gaussian_sigma;
      stages.filter = filters::filter_by_name("filter", filter);
      stages.filter.gaussian_sigma = sigma;
      stages.render.spacing = {stages.sampling.ascan_spacing_um, stages.sampling.bscan_spacing_um,
                               stages.sampling.axial_um_per_px};
      stages.live_image = config.out_dir / "render.png";
      if (frames == "<ring>.frames") frames = config.ring_name + ".frames";
      stages.frame_ring = frames == "none" ? "" : frames;
      stages.frame_group = view_group;
      volume_stages = std::make_unique<live::VolumeStages>(stages);
      processor.set_stage(volume_stages.get());
    }
    std::unique_ptr<live::ProcessingViewControl> controls;
    std::unique_ptr<live::ViewSocket> socket;
    if (!view_socket.empty()) {
      if (!volume_stages) {
        throw ioct::ConfigError("view-socket", "'" + view_socket + "'",
                                "needs the live stages (not with --no-stages)");
      }
      live::ViewSocketConfig socket_config;
      socket_config.path = view_socket;
      socket_config.group = view_group;
      socket_config.snapshot_dir = snapshot_dir == "<out>/snapshots"
                                       ? config.out_dir / "snapshots"
                                       : std::filesystem::path(snapshot_dir);
      // The views' parameters and the processing's dB range, as the viewers change them.
      controls = std::make_unique<live::ProcessingViewControl>(
          *volume_stages, [&processor] { return processor.db_range(); },
          [&processor](const DbScaleConfig& scale) { processor.set_db_range(scale); });
      socket = std::make_unique<live::ViewSocket>(socket_config, *controls);
    }
    processor.set_status_stream(&std::cerr);
    g_processor = &processor;
    ioct::install_stop_handler(on_stop_signal);
    const RunSummary summary = processor.run();
    g_processor = nullptr;
    socket.reset();

    std::cerr << "ioct-gpu: stopped (" << to_string(summary.stop_reason) << ") after "
              << summary.counters.groups_processed << " groups, "
              << summary.counters.volumes_completed << " volumes" << std::endl;
    if (summary.images) {
      std::cout << "bscan:   " << summary.images->bscan_png.string() << "\n"
                << "enface:  " << summary.images->enface_png.string() << "\n";
    } else {
      std::cout << "no images: no B-scan was processed\n";
    }
    std::cout << "summary: " << summary.summary_json.string() << std::endl;
    return EXIT_SUCCESS;
  } catch (const ioct::ConfigError& e) {
    std::cerr << "ioct-gpu: invalid option: " << e.what() << "\n";
    return 2;
  } catch (const BackendUnavailable& e) {
    std::cerr << "ioct-gpu: " << e.what() << "\n";
    return 2;
  } catch (const ioct::shm::RingError& e) {
    std::cerr << "ioct-gpu: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "ioct-gpu: error: " << e.what() << "\n";
    return 1;
  }
}
