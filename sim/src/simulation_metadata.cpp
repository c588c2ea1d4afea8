#include "ioct/sim/simulation_metadata.hpp"

#include "ioct/sim/simulated_digitizer.hpp"

namespace ioct::sim {

nlohmann::json to_json(const SimulationConfig& s) {
  using nlohmann::json;
  json tabulated = json::array();
  for (const SpectrumPoint& p : s.source.tabulated) tabulated.push_back({p.wavelength_nm, p.power});
  json instruments = json::array();
  for (const InstrumentConfig& tool : s.instruments) {
    instruments.push_back({{"kind", to_string(tool.kind)},
                           {"pose",
                            {{"tip_x", tool.pose.tip_x},
                             {"tip_y", tool.pose.tip_y},
                             {"tip_depth_fraction", tool.pose.tip_depth_fraction},
                             {"yaw_deg", tool.pose.yaw_deg},
                             {"pitch_deg", tool.pose.pitch_deg},
                             {"jaw_opening_deg", tool.pose.jaw_opening_deg}}},
                           {"motion",
                            {{"velocity_x", tool.motion.velocity_x},
                             {"velocity_y", tool.motion.velocity_y},
                             {"velocity_depth", tool.motion.velocity_depth},
                             {"tremor_x", tool.motion.tremor_x},
                             {"tremor_y", tool.motion.tremor_y},
                             {"tremor_depth", tool.motion.tremor_depth},
                             {"tremor_hz", tool.motion.tremor_hz},
                             {"jaw_cycle_deg", tool.motion.jaw_cycle_deg},
                             {"jaw_cycle_hz", tool.motion.jaw_cycle_hz}}}});
  }
  const RetinaConfig& r = s.retina;
  const AnteriorSegmentConfig& a = s.anterior;
  return {
      {"simulator", "ioct sim"},
      {"seed", s.seed},
      {"preset", to_string(s.preset)},
      {"speckle_grain_um", s.speckle_grain_um},
      {"source",
       {{"center_wavelength_nm", s.source.center_wavelength_nm},
        {"sweep_bandwidth_nm", s.source.sweep_bandwidth_nm},
        {"shape", to_string(s.source.shape)},
        {"envelope_fwhm_nm", s.source.envelope_fwhm_nm},
        {"super_gaussian_order", s.source.super_gaussian_order},
        {"tabulated", tabulated},
        {"rolloff_6db_depth_mm", s.source.rolloff_6db_depth_mm},
        {"axial_pixel_um", s.source.axial_pixel_um()}}},
      {"interferometer",
       {{"dispersion_c2", s.interferometer.dispersion_c2},
        {"dispersion_c3", s.interferometer.dispersion_c3}}},
      {"detector",
       {{"adc_offset_counts", s.detector.adc_offset_counts},
        {"reference_dc_counts", s.detector.reference_dc_counts},
        {"fringe_counts", s.detector.fringe_counts},
        {"fixed_pattern_counts", s.detector.fixed_pattern_counts},
        {"read_noise_counts", s.detector.read_noise_counts},
        {"shot_noise_counts", s.detector.shot_noise_counts},
        {"rin_counts", s.detector.rin_counts},
        {"sweep_power_jitter", s.detector.sweep_power_jitter}}},
      {"retina",
       {{"field_half_width_mm", r.field_half_width_mm},
        {"rpe_depth_fraction", r.rpe_depth_fraction},
        {"curvature_fraction", r.curvature_fraction},
        {"tilt_x_fraction", r.tilt_x_fraction},
        {"tilt_y_fraction", r.tilt_y_fraction},
        {"fovea_x", r.fovea_x},
        {"fovea_y", r.fovea_y},
        {"fovea_radius_mm", r.fovea_radius_mm},
        {"foveal_pit_depth", r.foveal_pit_depth},
        {"tissue_index", r.tissue_index},
        {"speckle_contrast", r.speckle_contrast},
        {"scattering_gain", r.scattering_gain},
        {"macular_hole",
         {{"enabled", r.macular_hole.enabled}, {"radius_mm", r.macular_hole.radius_mm}}},
        {"membrane",
         {{"enabled", r.membrane.enabled},
          {"radius_mm", r.membrane.radius_mm},
          {"center_x", r.membrane.center_x},
          {"center_y", r.membrane.center_y}}},
        {"disc",
         {{"enabled", r.disc.enabled},
          {"radius_mm", r.disc.radius_mm},
          {"center_x", r.disc.center_x},
          {"center_y", r.disc.center_y},
          {"margin_mm", r.disc.margin_mm},
          {"cup_radius_mm", r.disc.cup_radius_mm},
          {"cup_depth_um", r.disc.cup_depth_um},
          {"nerve_scatter", r.disc.nerve_scatter}}}}},
      {"anterior",
       {{"field_half_width_mm", a.field_half_width_mm},
        {"apex_depth_fraction", a.apex_depth_fraction},
        {"chamber_depth_mm", a.chamber_depth_mm},
        {"pupil_radius_mm", a.pupil_radius_mm}}},
      {"mirror",
       {{"field_half_width_mm", s.mirror.field_half_width_mm},
        {"depth_fraction", s.mirror.depth_fraction},
        {"tilt_x_fraction", s.mirror.tilt_x_fraction},
        {"tilt_y_fraction", s.mirror.tilt_y_fraction},
        {"reflectivity", s.mirror.reflectivity}}},
      {"instruments", instruments},
      {"bench",
       {{"mirror_natural_hz", s.bench.mirrors.natural_hz},
        {"mirror_damping", s.bench.mirrors.damping}}},
      {"scan",
       {{"ascans_per_bscan", s.scan.ascans_per_bscan},
        {"bscans_per_volume", s.scan.bscans_per_volume},
        {"center_x", s.scan.center_x},
        {"center_y", s.scan.center_y},
        {"extent_x", s.scan.extent_x},
        {"extent_y", s.scan.extent_y}}},
  };
}

recording::RecordingMetadata recording_metadata(const SimulatedDigitizer& digitizer) {
  const hal::DigitizerConfig& c = digitizer.config();
  const SimulationConfig& s = digitizer.simulation();
  recording::RecordingMetadata m;
  m.geometry.samples_per_ascan = c.samples_per_ascan;
  m.geometry.ascans_per_bscan = c.ascans_per_bscan;
  m.geometry.flyback_sweeps = c.flyback_sweeps;
  m.geometry.bscans_per_group = c.bscans_per_group;
  m.geometry.bscans_per_volume = s.scan.bscans_per_volume;
  m.geometry.ascan_rate_hz = c.ascan_rate_hz;
  m.geometry.sample_bits = c.sample_bits;
  m.geometry.clock_source = std::string(hal::to_string(c.clock_source));
  m.scan.center_x = s.scan.center_x;
  m.scan.center_y = s.scan.center_y;
  m.scan.extent_x = s.scan.extent_x;
  m.scan.extent_y = s.scan.extent_y;
  m.resampling_coefficients = digitizer.sampling().calibration.coefficients;
  m.dispersion_c2 = s.interferometer.dispersion_c2;
  m.dispersion_c3 = s.interferometer.dispersion_c3;
  m.acquisition = to_json(s);
  m.has_truth = true;
  m.truth_tools = static_cast<std::uint32_t>(s.instruments.size());
  return m;
}

}  // namespace ioct::sim
