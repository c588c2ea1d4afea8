// ioct-render: a volume file (NRRD as ioct-process and ioct-vol-import write it, or a Heidelberg
// .vol export) rendered to PNG in every mode asked for, with the same renderers as the live
// system; optionally a turntable sequence (one full turn about the A-scan axis).
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "ioct/common/atomic_file.hpp"
#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/offline/volume_file.hpp"
#include "ioct/gpu/render/png_rgba.hpp"
#include "ioct/gpu/render/renderer.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ioct::gpu;
using namespace ioct::gpu::render;

// A .vol's own lines as surfaces: ILM (line 0) and Bruch's membrane (line 1), which stands in for
// the RPE centre a few px above it.
segmentation::Surfaces surfaces_from_vol_layers(const offline::VolumeFile& file) {
  const Volume& v = file.volume;
  segmentation::Surfaces s;
  s.reset(v.bscans(), v.ascans(), v.depth());
  for (std::uint32_t b = 0; b < v.bscans() && b < file.vol_layers.size(); ++b) {
    const auto& layers = file.vol_layers[b];
    for (std::uint32_t a = 0; a < v.ascans(); ++a) {
      if (layers.size() > 0) s.ilm[s.index(b, a)] = layers[0][a];
      if (layers.size() > 1) s.rpe[s.index(b, a)] = layers[1][a];
    }
  }
  return s;
}

std::vector<RenderMode> parse_modes(const std::string& text) {
  std::vector<RenderMode> modes;
  if (text == "all") {
    return {RenderMode::basic,
            RenderMode::enhanced,
            RenderMode::layer_aware,
            RenderMode::axial_colorization,
            RenderMode::la_mip_composite,
            RenderMode::bscan_slice,
            RenderMode::en_face_slice};
  }
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string name =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    modes.push_back(parse_render_mode(name));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return modes;
}

// The values the flags fill.
struct Options {
  std::string input;
  std::string out = ".";
  std::string modes_text = "enhanced";
  std::string backend_text = "auto";
  std::string preset_text = "retina";
  std::string layers = "auto";
  std::string filter = "auto";
  std::string name_prefix;
  std::int64_t width = 1024;
  std::int64_t height = 768;
  std::uint32_t turntable = 0;
  unsigned threads = 0;
  std::optional<double> bscan_spacing_um;
  RenderConfig config;
  // Each step of the enhanced ray caster off on its own: Viehland Fig. 4's progression.
  bool no_threshold = false, no_edge = false, no_feature = false, no_depth_cues = false,
       no_phong = false, no_colorize = false;
};

// The command line: the input, the outputs, the view and each renderer's settings.
void add_options(CLI::App& app, Options& o) {
  RenderConfig& config = o.config;
  app.add_option(
         "input", o.input,
         "volume file: .nrrd (ioct-process, ioct-vol-import), Heidelberg .vol or Bioptigen .OCT "
         "(told apart by their contents)")
      ->required();
  app.add_option("--out", o.out, "directory for <mode>.png and summary.json");
  app.add_option("--mode", o.modes_text,
                 "comma-separated: basic, enhanced, layer-aware, axial-colorization, la-mip, "
                 "bscan, en-face; or all");
  app.add_option("--preset", o.preset_text, "enhanced ray casting preset: retina or anterior");
  app.add_option("--backend", o.backend_text, "cpu, cuda or auto");
  app.add_option("--layers", o.layers,
                 "reference RPE: auto (a .vol's own BM line, else segment), segment, vol, none");
  app.add_option("--filter", o.filter, "median + Gaussian before segmenting: auto, yes, no");
  app.add_option("--width", o.width, "output width per eye, px");
  app.add_option("--height", o.height, "output height, px");
  app.add_option("--azimuth", config.view.azimuth_deg, "deg about the A-scan axis");
  app.add_option("--elevation", config.view.elevation_deg, "deg above the tissue plane");
  app.add_option("--zoom", config.view.zoom, "1: the volume's bounding sphere fits");
  app.add_option("--pan-x", config.view.pan_x, "image-plane shift (volume extents)");
  app.add_option("--pan-y", config.view.pan_y, "image-plane shift (volume extents)");
  app.add_flag("--stereo", config.view.stereo, "side-by-side stereo pair (volume modes)");
  app.add_option("--stereo-angle", config.view.stereo_angle_deg, "deg between the eyes");
  app.add_option("--threshold", config.enhanced.threshold, "enhanced: intensity threshold");
  app.add_option("--shadow-steps", config.layer_aware.shadow_steps,
                 "layer-aware N_s (20 limited, 200 full, 0 none)");
  app.add_option("--i-min", config.layer_aware.i_min, "layer-aware opacity ramp start");
  app.add_option("--i-max", config.layer_aware.i_max, "layer-aware opacity ramp end");
  app.add_option("--step", config.step_voxels, "ray step in voxels");
  app.add_option("--bscan-spacing-um", o.bscan_spacing_um,
                 "override the B-scan spacing (a single B-scan renders as a slab this thick)");
  app.add_option("--turntable", o.turntable,
                 "also write N frames of one full turn per volume mode");
  app.add_option("--prefix", o.name_prefix, "prefix of the PNG names");
  app.add_option("--threads", o.threads, "CPU threads");
  app.add_flag("--no-threshold", o.no_threshold, "enhanced: no intensity threshold");
  app.add_flag("--no-edge", o.no_edge, "enhanced: no gradient edge enhancement (kg1, kg2)");
  app.add_flag("--no-feature", o.no_feature, "enhanced: no feature enhancement (kf1, kf2)");
  app.add_flag("--no-depth-cues", o.no_depth_cues, "enhanced: no depth dimming and blue hue");
  app.add_flag("--no-phong", o.no_phong, "enhanced: no Phong shading");
  app.add_flag("--no-colorize", o.no_colorize, "layer-aware: lightness only (Weiss Fig. 4 A1)");
  app.add_flag("--axial-phong", config.axial.phong, "axial colorization with Phong");
  app.add_option("--axial-shadow-steps", config.axial.shadow_steps,
                 "axial colorization with N_s shadow steps instead of Phong (Weiss Fig. 4 B4)");
  app.add_option("--bscan", config.slice.bscan, "bscan mode: the B-scan shown (-1: the centre)");
  app.add_option("--en-face-depth", config.slice.en_face_depth_px,
                 "en-face mode: depth px (-1: the centre), or below the RPE with --below-rpe");
  app.add_flag("--below-rpe", config.slice.en_face_relative_to_rpe,
               "en-face mode: --en-face-depth counts from the RPE");
}

// The output size and the enhanced preset with the flags' changes to it, into the config.
void complete_config(Options& o) {
  RenderConfig& config = o.config;
  if (o.width < 1 || o.width > 8192) {
    throw ioct::ConfigError("render.view.output_width", ioct::format_value(o.width),
                            "must be in [1, 8192]");
  }
  if (o.height < 1 || o.height > 8192) {
    throw ioct::ConfigError("render.view.output_height", ioct::format_value(o.height),
                            "must be in [1, 8192]");
  }
  config.view.output_width = static_cast<std::uint32_t>(o.width);
  config.view.output_height = static_cast<std::uint32_t>(o.height);
  const LayerAwareConfig layer_aware = config.layer_aware;
  const double threshold = config.enhanced.threshold;
  config.enhanced = enhanced_preset(parse_preset(o.preset_text));
  config.enhanced.threshold = threshold;
  if (o.no_threshold) config.enhanced.use_threshold = false;
  if (o.no_edge) config.enhanced.edge_enhancement = false;
  if (o.no_feature) config.enhanced.feature_enhancement = false;
  if (o.no_depth_cues) config.enhanced.depth_cues = false;
  if (o.no_phong) config.enhanced.phong = false;
  config.layer_aware = layer_aware;
  if (o.no_colorize) config.layer_aware.colorize = false;
  config.cpu_threads = o.threads;
}

// --layers and --filter: one of their words each.
void check_layer_choices(const Options& o) {
  if (o.layers != "auto" && o.layers != "segment" && o.layers != "vol" && o.layers != "none") {
    throw ioct::ConfigError("layers", "'" + o.layers + "'", "must be auto, segment, vol or none");
  }
  if (o.filter != "auto" && o.filter != "yes" && o.filter != "no") {
    throw ioct::ConfigError("filter", "'" + o.filter + "'", "must be auto, yes or no");
  }
}

// The voxel spacings: the file's, the B-scan spacing overridden by the flag when given.
segmentation::VolumeSampling sampling_of(const offline::VolumeFile& loaded,
                                         const std::optional<double>& bscan_spacing_um) {
  segmentation::VolumeSampling sampling;
  if (loaded.spacing) {
    sampling.axial_um_per_px = loaded.spacing->axial_per_px;
    sampling.ascan_spacing_um = loaded.spacing->ascan;
    sampling.bscan_spacing_um = loaded.spacing->bscan;
  }
  if (bscan_spacing_um) sampling.bscan_spacing_um = *bscan_spacing_um;
  return sampling;
}

// The RPE the layer-aware modes shade against, and its name for the report.
struct ReferenceLayer {
  std::optional<segmentation::Surfaces> surfaces;
  std::string name = "none";
};

// The reference layer as --layers asks: the file's own line, segmented, or none.
ReferenceLayer reference_layer(const Options& o, const offline::VolumeFile& loaded, Backend backend,
                               const segmentation::VolumeSampling& sampling) {
  const bool has_vol_layers = !loaded.vol_layers.empty();
  ReferenceLayer reference;
  if (o.layers == "vol" || (o.layers == "auto" && has_vol_layers)) {
    if (!has_vol_layers) {
      throw ioct::ConfigError("layers", "'vol'", "needs a .vol input (it has the lines)");
    }
    reference.surfaces = surfaces_from_vol_layers(loaded);
    reference.name = "the file's Bruch's membrane line";
  } else if (o.layers == "segment" || o.layers == "auto") {
    const bool do_filter = o.filter == "yes" || (o.filter == "auto" && !loaded.already_filtered);
    Volume filtered;
    if (do_filter) {
      filters::make_volume_filter(backend, {}, o.threads == 0 ? 2 : o.threads)
          ->filter_volume(loaded.volume, filtered);
    }
    segmentation::Surfaces s;
    make_segmenter(backend, {}, sampling, o.threads == 0 ? 2 : o.threads)
        ->segment_volume(do_filter ? filtered : loaded.volume, s);
    reference.surfaces = std::move(s);
    reference.name = "segmented RPE";
  }
  return reference;
}

// Every mode asked for as <prefix><mode>.png (and its turntable frames); returns what was written.
nlohmann::json render_images(const Options& o, Renderer& renderer,
                             const std::vector<RenderMode>& modes) {
  const RenderConfig& config = o.config;
  nlohmann::json written = nlohmann::json::array();
  RgbaImage image;
  for (const RenderMode mode : modes) {
    RenderConfig c = config;
    c.mode = mode;
    const std::string base = o.name_prefix + std::string(to_string(mode));
    renderer.render(c, image);
    write_png(fs::path(o.out) / (base + ".png"), image);
    written.push_back(base + ".png");
    if (o.turntable > 0 && is_volume_mode(mode)) {
      for (std::uint32_t f = 0; f < o.turntable; ++f) {
        c.view.azimuth_deg = config.view.azimuth_deg + 360.0 * f / o.turntable;
        renderer.render(c, image);
        char name[64];
        std::snprintf(name, sizeof name, "_turn%04u.png", f);
        write_png(fs::path(o.out) / (base + name), image);
      }
      written.push_back(base + "_turn*.png (" + std::to_string(o.turntable) + ")");
    }
  }
  return written;
}

// The command's work: settings, the volume and its reference layer, the images and the summary.
int render_volume(Options& o) {
  complete_config(o);
  const std::vector<RenderMode> modes = parse_modes(o.modes_text);
  const Backend backend = parse_backend(o.backend_text);
  check_layer_choices(o);
  o.config.validate();

  const offline::VolumeFile loaded = offline::read_volume_file(o.input);
  const segmentation::VolumeSampling sampling = sampling_of(loaded, o.bscan_spacing_um);
  o.config.spacing = {sampling.ascan_spacing_um, sampling.bscan_spacing_um,
                      sampling.axial_um_per_px};
  o.config.validate();

  // The reference layer.
  const ReferenceLayer reference = reference_layer(o, loaded, backend, sampling);

  const auto renderer = make_renderer(backend, o.threads);
  renderer->set_volume(loaded.volume, reference.surfaces ? &*reference.surfaces : nullptr);
  fs::create_directories(o.out);
  const auto start = std::chrono::steady_clock::now();
  const nlohmann::json written = render_images(o, *renderer, modes);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const nlohmann::json summary = {{"input", fs::path(o.input).filename().string()},
                                  {"kind", loaded.kind},
                                  {"backend", std::string(renderer->backend_name())},
                                  {"bscans", loaded.volume.bscans()},
                                  {"ascans", loaded.volume.ascans()},
                                  {"depth", loaded.volume.depth()},
                                  {"reference_layer", reference.name},
                                  {"seconds", seconds},
                                  {"images", written}};
  ioct::write_text_file_atomically(fs::path(o.out) / (o.name_prefix + "summary.json"),
                                   summary.dump(2) + "\n");
  std::cout << "ioct-render: " << o.input << " (" << loaded.kind << ", " << loaded.volume.bscans()
            << " x " << loaded.volume.ascans() << " x " << loaded.volume.depth()
            << "), reference: " << reference.name << ", " << renderer->backend_name() << ", "
            << written.size() << " outputs in " << seconds << " s -> " << o.out << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{
      "ioct-render: a volume file (.nrrd, Heidelberg .vol or Bioptigen .OCT) rendered to PNG"};
  add_options(app, options);
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;
  return ioct::run_command("ioct-render", [&]() -> int { return render_volume(options); });
}
