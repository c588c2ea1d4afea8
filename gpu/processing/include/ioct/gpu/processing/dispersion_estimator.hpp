// Automatic dispersion estimation: the c2, c3 (dispersion.hpp) that make the tissue of a group
// sharpest, checked on the processed volume so that it never makes the image worse than none.
//
// Why it is more than "sharpest A-scans": on a real spectrometer set (2048 lambda-linear samples,
// 400 A-scans, low signal) the tool returned c2 = -49.2, c3 = 33.9 rad that blurred the image.
// Two causes, both fixed: ioct-dispersion did not resample when given only a calibration (so it
// compensated the sampling's chirp; see dispersion_main.cpp), and the metric scored artifacts.
// A source power (or exposure) that varies from sweep to sweep leaves a residue of the
// background in every A-scan (the group's mean removes only its mean): a DC peak and
// fixed-pattern lines, sharp at (0, 0), brighter than weak tissue; and the A-scans of most
// energy are those of most residue. So:
//
// Group: the group less its background residue: each raw spectrum r is fitted, by least squares,
// as x + y b (b: the group's mean spectrum; x: a detector offset; y: the source power) and
// becomes r - x - (y - 1) b (rounded to u16). Fringes are untouched (they are orthogonal to b
// and to a constant); the mean, hence the chain's background, stays the same. The metric and
// the check both use it. Spectra are then made by the chain's own code: its background (the
// group's mean), resampling and window (SpectralTables::spectrum_value), and its correction
// (dispersion_correction), so sign and scale are the chain's by construction.
//
// Rows the metric leaves out (found once, uncompensated):
//   - the DC region: depths below `dc_rows` (0: samples / 64, at least 8);
//   - fixed-pattern lines the fit could not remove (a reflection whose strength varies on its
//     own): rows whose phase is the same, up to sign, across the A-scans, i.e. a phase coherence
//     |mean_a exp(2 i theta_a(d))| above max(`fixed_coherence`, 4 / sqrt(A-scans)) (moving tissue
//     has random phases: about 1 / sqrt(A-scans)), and `fixed_margin` rows either side. Phase
//     only, so one bright A-scan cannot make a row look coherent; a stationary reflector with a
//     stable phase (a phantom on a table) is taken for a fixed-pattern line too.
//
// Metric: per A-scan, the intensities I_d = |X_d|^2 of the rows kept give
//     S = sum_d I_d^2 / (sum_d I_d)^2   (1 / the number of rows the energy is spread over)
// and the metric is the mean of S weighted by each A-scan's signal: its energy in the rows kept
// above the group's 10th percentile (about the energy of an A-scan without tissue). The A-scans
// used are the brightest by that same energy.
//
// Search: a grid over c2 (c3 = 0), then over c3, then a coordinate search that halves its step
// around the best point until the step is below `tolerance`.
//
// Depth consistency: for a non-zero result, c2 is searched again over the tissue above and
// below its median row (DispersionEstimate::depth_dependent).
//
// Check: the group (less its residue) is then processed by the chain itself (CpuOctProcessor)
// at the estimate and at (0, 0), and the processed volumes' standard sharpness
// (volume_sharpness.hpp) compared over the same rows: below the DC region and away from the
// fixed-pattern rows, each widened by the rows the correction spreads a line over
// (chirp_spread_rows), so that the comparison is of tissue. Unless the estimate is sharper by
// at least 0.1%, (0, 0) is returned and `rejected` says so.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ioct/gpu/processing/fftw_c2c_plan.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"

namespace ioct::gpu {

struct DispersionSearch {
  double c2_limit = 200.0;  // c2 searched in [-c2_limit, c2_limit] radians
  double c3_limit = 100.0;  // c3 searched in [-c3_limit, c3_limit] radians
  std::uint32_t grid_points = 41;
  double tolerance = 0.02;         // radians: the final step of the coordinate search
  std::uint32_t ascans = 256;      // brightest A-scans used
  std::uint32_t dc_rows = 0;       // rows next to zero delay left out; 0: samples / 64, >= 8
  double fixed_coherence = 0.2;    // coherence above which a row is a fixed-pattern line
  std::uint32_t fixed_margin = 3;  // rows left out either side of a fixed-pattern line
  bool check_on_chain = true;      // compare with no correction on the processed volume

  // Throws ConfigError naming the key.
  void validate() const;
};

struct DispersionEstimate {
  double c2 = 0.0;  // what to apply: the search's result, or 0 when it lost the check
  double c3 = 0.0;
  double searched_c2 = 0.0;  // the search's result, before the check
  double searched_c3 = 0.0;
  double sharpness = 0.0;                // metric at (searched_c2, searched_c3)
  double sharpness_uncompensated = 0.0;  // metric at (0, 0)
  // The standard sharpness of the volume the chain makes at the search's result and at (0, 0)
  // (0 when not checked).
  double processed_sharpness = 0.0;
  double processed_sharpness_uncompensated = 0.0;
  bool checked = false;
  bool rejected = false;  // the search's result was not sharper on the processed volume
  std::uint32_t ascans_used = 0;
  std::uint32_t evaluations = 0;
  std::uint32_t dc_rows = 0;
  std::vector<std::uint32_t> fixed_pattern_rows;  // rows found to be fixed-pattern lines
  // Dispersion is the same at every depth; a sweep that is not linear in k as processed (no or
  // a wrong calibration) blurs deeper layers more, and its "best c2" grows with depth. So c2 is
  // searched again (c3 as found) over the tissue above and below its median row `depth_split`;
  // `depth_dependent` when they differ by more than max(3 rad, 10% of |c2|). Only for a
  // non-zero search result.
  double c2_shallow = 0.0;
  double c2_deep = 0.0;
  std::uint32_t depth_split = 0;
  bool depth_dependent = false;
};

// Rows a correction can spread a line over, either side: the instantaneous frequency of its
// chirp, phi'(t) / pi rows, that 95% of the window's energy (window^2) stays within.
std::uint32_t chirp_spread_rows(const DispersionConfig& correction, std::span<const float> window);

class DispersionEstimator {
 public:
  // `processing` gives the background mode, resampling and window to apply first (its
  // dispersion is ignored; its background is the group's own mean). Throws ConfigError.
  DispersionEstimator(const OctProcessorConfig& processing, const DispersionSearch& search);

  // Picks the A-scans of `group` (header checked against `geometry`), prepares their
  // background-free, windowed spectra and finds the rows to leave out. Keeps a copy of the group
  // for the check. Throws std::invalid_argument for a group the chain rejects and ConfigError
  // for a config that does not fit the geometry.
  void load(const shm::RingGeometry& geometry, const RawGroup& group);

  // The metric at (c2, c3) over the loaded A-scans.
  double sharpness(double c2, double c3);

  // The standard sharpness of the loaded group processed by the chain with (c2, c3), over the
  // rows kept when comparing a correction of (spread_c2, spread_c3) with none.
  double processed_sharpness(double c2, double c3, double spread_c2, double spread_c3) const;

  // The search, the depth consistency, then check() (unless search.check_on_chain is off).
  // Requires load().
  DispersionEstimate estimate();

  // Fills e's processed figures for (e.searched_c2, e.searched_c3) and sets e.c2, e.c3 to them,
  // or to 0 with e.rejected when they are not sharper than none by at least 0.1%. Requires
  // load().
  void check(DispersionEstimate& e) const;

  std::uint32_t dc_rows() const noexcept { return dc_rows_; }
  const std::vector<std::uint32_t>& fixed_pattern_rows() const noexcept { return fixed_rows_; }

 private:
  // Rows kept by the metric and the check: all but the DC region and the fixed-pattern rows
  // (with their margin), each widened by `spread` rows.
  std::vector<std::uint8_t> kept_rows(std::uint32_t spread) const;
  // The metric over the rows `kept` flags.
  double metric(double c2, double c3, const std::vector<std::uint8_t>& kept);
  // The c2 of the best metric over `kept`, searched around `c2` with c3 fixed.
  double best_c2(const std::vector<std::uint8_t>& kept, double c2, double c3);
  void check_depth_consistency(DispersionEstimate& e);

  OctProcessorConfig processing_;
  DispersionSearch search_;
  std::uint32_t samples_ = 0;
  std::uint32_t ascans_ = 0;
  std::vector<float> spectra_;   // [ascan][sample], real
  std::vector<double> weights_;  // per A-scan used: its signal
  // The metric's transforms, allocated and planned once per load().
  FftwArray<std::complex<float>> metric_in_;
  FftwArray<std::complex<float>> metric_out_;
  FftwC2cPlan metric_plan_;
  std::uint32_t dc_rows_ = 0;
  std::vector<std::uint32_t> fixed_rows_;
  std::vector<std::uint8_t> kept_;       // per row of the positive depths: 1 when in the metric
  std::uint32_t tissue_median_row_ = 0;  // half the tissue's energy above, half below
  std::uint32_t evaluations_ = 0;
  shm::RingGeometry geometry_;
  shm::SlotHeader header_{};
  std::vector<std::uint16_t> group_;  // the loaded group less its residue, for the check
  std::vector<float> window_;
};

// One line for people: what the check found ("estimate kept: ..." / "estimate rejected: ...").
std::string describe_check(const DispersionEstimate& estimate);

}  // namespace ioct::gpu
