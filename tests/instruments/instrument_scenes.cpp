#include "instrument_scenes.hpp"

#include <stdexcept>

#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/sim/retina_model.hpp"

namespace ioct::instruments_test {

std::vector<InstrumentScene> instrument_scenes() {
  using K = sim::InstrumentKind;
  return {
      {"forceps_approaching", K::forceps, 0.1f, 0.0f, 250.0, 0.0f},
      {"forceps_approaching_open", K::forceps, -0.2f, 0.1f, 120.0, 160.0f, 25.0f, 20.0f},
      {"forceps_touching", K::forceps, 0.3f, -0.1f, 0.0, 45.0f},
      {"forceps_indenting", K::forceps, -0.3f, 0.05f, -30.0, 200.0f, 20.0f},
      {"forceps_below_ilm", K::forceps, 0.2f, 0.2f, -100.0, 300.0f, 30.0f},
      {"needle_approaching", K::needle, -0.1f, -0.2f, 180.0, 120.0f},
      {"needle_touching", K::needle, 0.25f, 0.15f, 0.0, 10.0f, 15.0f},
      {"needle_below_ilm", K::needle, 0.0f, 0.3f, -80.0, 250.0f, 35.0f},
      {"scraper_approaching", K::scraper, 0.15f, -0.25f, 150.0, 200.0f},
      {"scraper_touching", K::scraper, -0.25f, -0.05f, 0.0, 30.0f, 20.0f},
  };
}

namespace {

// `spec` (its scan and its tools set) through the CPU chain and the filters, with the sampling of
// its raster and the truth at the first tool's tip.
SceneVolume simulate(seg_test::SimulatedVolumeSpec spec) {
  SceneVolume out;
  const sim::SimulationConfig& simulation = spec.simulation;
  const std::uint32_t depth = spec.samples_per_ascan / 2;
  const double um_per_px = simulation.source.axial_pixel_um();
  const sim::RetinaModel retina(simulation.retina, um_per_px, depth);
  spec.filter = false;
  out.spec = spec;
  out.volume = seg_test::make_simulated_volume(spec);
  gpu::filters::make_volume_filter(gpu::Backend::cpu, {}, 1)
      ->filter_volume(out.volume.volume, out.filtered);
  const double field_um = 2000.0 * simulation.field_half_width_mm();
  out.sampling.axial_um_per_px = out.volume.axial_um_per_px;
  out.sampling.ascan_spacing_um = field_um * simulation.scan.extent_x / (spec.ascans - 1);
  out.sampling.bscan_spacing_um = field_um * simulation.scan.extent_y / (spec.bscans - 1);

  // The poses as the simulator states them (the tools do not move in these scenes); the first
  // tool's tip with the surfaces under it.
  sim::ToolState tip{};
  for (const sim::InstrumentConfig& tool : simulation.instruments) {
    const sim::InstrumentModel model(tool, simulation.field_half_width_mm(), um_per_px, depth);
    const sim::ToolState state = model.tip_state(tool.pose);
    if (out.tool_tips.empty()) tip = state;
    out.tool_tips.push_back(sim::tip_voxel(state, simulation.scan));
  }
  out.tip = out.tool_tips.at(0);
  const sim::ColumnTruth under_tip = retina.layers({tip.tip_x, tip.tip_y});
  out.ilm_px = under_tip.ilm_px;
  out.rpe_px = under_tip.rpe_px;
  out.to_ilm_um = (out.ilm_px - out.tip.depth_px) * um_per_px;
  out.to_rpe_um = (out.rpe_px - out.tip.depth_px) * um_per_px;
  return out;
}

}  // namespace

SceneVolume make_scene_volume(const InstrumentScene& scene, std::uint32_t ascans,
                              std::uint32_t bscans) {
  seg_test::SimulatedVolumeSpec spec;
  spec.ascans = ascans;
  spec.bscans = bscans;
  sim::SimulationConfig& simulation = spec.simulation;
  // The default raster's spacing (512 x 128 over scan units +-1), about the tip.
  simulation.scan.extent_x = static_cast<float>(ascans - 1) / 511.0f;
  simulation.scan.extent_y = static_cast<float>(bscans - 1) / 127.0f;
  simulation.scan.center_x = scene.tip_x;
  simulation.scan.center_y = scene.tip_y;
  simulation.scan.ascans_per_bscan = ascans;
  simulation.scan.bscans_per_volume = bscans;

  const std::uint32_t depth = spec.samples_per_ascan / 2;
  const double um_per_px = simulation.source.axial_pixel_um();
  const sim::RetinaModel retina(simulation.retina, um_per_px, depth);
  const sim::ColumnTruth under = retina.layers({scene.tip_x, scene.tip_y});
  const double tip_px = under.ilm_px - scene.above_ilm_um / um_per_px;

  sim::InstrumentConfig tool;
  tool.kind = scene.kind;
  tool.pose.tip_x = scene.tip_x;
  tool.pose.tip_y = scene.tip_y;
  tool.pose.tip_depth_fraction = static_cast<float>(tip_px / depth);
  tool.pose.yaw_deg = scene.yaw_deg;
  tool.pose.pitch_deg = scene.pitch_deg;
  tool.pose.jaw_opening_deg = scene.jaw_opening_deg;
  simulation.instruments.push_back(tool);
  return simulate(spec);
}

SceneVolume make_field_volume(const std::vector<sim::InstrumentConfig>& tools, std::uint32_t ascans,
                              std::uint32_t bscans) {
  for (const sim::InstrumentConfig& tool : tools) {
    const sim::ToolMotion& m = tool.motion;
    if (m.velocity_x != 0.0f || m.velocity_y != 0.0f || m.velocity_depth != 0.0f ||
        m.tremor_x != 0.0f || m.tremor_y != 0.0f || m.tremor_depth != 0.0f ||
        m.jaw_cycle_deg != 0.0f) {
      throw std::invalid_argument("a scene's tools stand still: no velocity, tremor or jaw cycle");
    }
  }
  seg_test::SimulatedVolumeSpec spec;
  spec.ascans = ascans;
  spec.bscans = bscans;
  spec.simulation.scan.ascans_per_bscan = ascans;
  spec.simulation.scan.bscans_per_volume = bscans;
  spec.simulation.instruments = tools;
  return simulate(spec);
}

}  // namespace ioct::instruments_test
