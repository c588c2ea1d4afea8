#include "ioct/gpu/processing/dispersion_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/processing/cpu_oct_processor.hpp"
#include "ioct/gpu/processing/fftw_c2c_plan.hpp"
#include "ioct/gpu/processing/group_check.hpp"
#include "ioct/gpu/processing/spectral_tables.hpp"
#include "ioct/gpu/processing/volume_sharpness.hpp"

namespace ioct::gpu {
namespace {

constexpr double kMinimumGain = 1.001;

// Forward complex FFTs of `count` real spectra of `samples`, as the chain does with dispersion.
FftwArray<std::complex<float>> transform(const float* spectra, std::uint32_t count,
                                         std::uint32_t samples) {
  FftwArray<std::complex<float>> in(std::size_t{count} * samples);
  FftwArray<std::complex<float>> out(std::size_t{count} * samples);
  for (std::size_t i = 0; i < std::size_t{count} * samples; ++i) in.data()[i] = {spectra[i], 0.0f};
  FftConfig fft;
  fft.rigor = FftRigor::estimate;
  const FftwC2cPlan plan(fft, samples, count, samples, in.data(), out.data());
  plan.execute(in.data(), out.data());
  return out;
}

// The group less its background residue: each spectrum r is fitted, by least squares, as
// x + y b (b: the group's mean spectrum, raw sample order; x: a detector offset, y: the source
// power) and becomes r - x - (y - 1) b, rounded: a spectrum of the mean power and offset, whose
// fringes are untouched (they are orthogonal to b and to a constant).
std::vector<std::uint16_t> without_residue(std::span<const std::uint16_t> spectra,
                                           std::span<const float> background) {
  const std::size_t n = background.size();
  double s1 = static_cast<double>(n);
  double sb = 0.0;
  double sbb = 0.0;
  for (const float b : background) {
    sb += b;
    sbb += double{b} * b;
  }
  const double det = s1 * sbb - sb * sb;
  std::vector<std::uint16_t> out(spectra.begin(), spectra.end());
  if (!(det > 1e-9 * s1 * sbb)) return out;  // a flat background: nothing to fit
  for (std::size_t first = 0; first + n <= spectra.size(); first += n) {
    double sr = 0.0;
    double srb = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      sr += spectra[first + j];
      srb += static_cast<double>(spectra[first + j]) * background[j];
    }
    const double x = (sr * sbb - srb * sb) / det;
    const double y = (srb * s1 - sr * sb) / det;
    for (std::size_t j = 0; j < n; ++j) {
      const double v = spectra[first + j] - x - (y - 1.0) * background[j];
      out[first + j] = static_cast<std::uint16_t>(std::clamp(std::lround(v), 0L, 65535L));
    }
  }
  return out;
}

}  // namespace

void DispersionSearch::validate() const {
  require_real_in_range("c2_limit", c2_limit, 0.0, 10000.0);
  require_real_in_range("c3_limit", c3_limit, 0.0, 10000.0);
  require_integer_in_range("grid_points", grid_points, 3, 1001);
  require_real_in_range("tolerance", tolerance, 1e-6, 100.0);
  require_integer_in_range("ascans", ascans, 1, 65536);
  require_integer_in_range("dc_rows", dc_rows, 0, 1u << 15);
  require_real_in_range("fixed_coherence", fixed_coherence, 0.0, 1.0);
  require_integer_in_range("fixed_margin", fixed_margin, 0, 1024);
}

std::uint32_t chirp_spread_rows(const DispersionConfig& correction, std::span<const float> window) {
  // Instantaneous frequency of the correction at sample j, in rows: phi'(j) N / (2 pi).
  const auto n = static_cast<std::uint32_t>(window.size());
  if (n < 2 || !correction.enabled()) return 0;
  std::vector<std::pair<double, double>> offsets(n);  // (|rows|, weight)
  double total = 0.0;
  for (std::uint32_t j = 0; j < n; ++j) {
    const double t = 2.0 * j / (n - 1.0) - 1.0;
    const double dphi_dt = 2.0 * correction.c2 * t + 3.0 * correction.c3 * t * t;
    const double rows = dphi_dt * (2.0 / (n - 1.0)) * n / (2.0 * std::numbers::pi);
    const double weight = double{window[j]} * window[j];
    offsets[j] = {std::abs(rows), weight};
    total += weight;
  }
  std::sort(offsets.begin(), offsets.end());
  double sum = 0.0;
  for (const auto& [rows, weight] : offsets) {
    sum += weight;
    if (sum >= 0.95 * total) return static_cast<std::uint32_t>(std::ceil(rows));
  }
  return static_cast<std::uint32_t>(std::ceil(offsets.back().first));
}

DispersionEstimator::DispersionEstimator(const OctProcessorConfig& processing,
                                         const DispersionSearch& search)
    : processing_(processing), search_(search) {
  processing_.dispersion = {};
  processing_.background.groups = 1;  // the group's own mean, as the estimator sees it
  processing_.validate();
  search_.validate();
}

void DispersionEstimator::load(const shm::RingGeometry& geometry, const RawGroup& group) {
  require_processable(geometry);
  processing_.validate_for(geometry);
  const shm::SlotHeader& h = group.header;
  if (auto problem = find_group_problem(h, geometry, group.spectra.size_bytes())) {
    throw std::invalid_argument("group " + std::to_string(h.group_index) + ": " + *problem);
  }
  samples_ = geometry.samples_per_ascan;
  const std::uint32_t depth = samples_ / 2;
  const SpectralTables tables = make_spectral_tables(processing_, samples_);
  const std::uint32_t width = h.active_ascan_end - h.active_ascan_begin;
  const auto record = [&](std::uint32_t b, std::uint32_t a) {
    return group_.data() +
           (std::size_t{b} * geometry.ascans_per_bscan + h.active_ascan_begin + a) * samples_;
  };

  // The chain's background: the group's mean spectrum; then the group less its residue, which
  // both the metric and the check see (the residue's mean is 0: the background stays the same).
  const auto mean_spectrum = [&](std::span<const std::uint16_t> spectra) {
    CpuBackgroundEstimator estimator;
    estimator.prepare(processing_.background, samples_, geometry.bscans_per_group,
                      geometry.ascans_per_bscan);
    for (std::uint32_t b = 0; b < h.bscan_count; ++b) {
      estimator.accumulate_bscan(
          b,
          spectra.data() +
              (std::size_t{b} * geometry.ascans_per_bscan + h.active_ascan_begin) * samples_,
          width);
    }
    estimator.finish(h.bscan_count, width);
    const std::span<const float> mean = estimator.background();
    return std::vector<float>(mean.begin(), mean.end());
  };
  if (processing_.background.mode != BackgroundMode::none) {
    group_ = without_residue(group.spectra, mean_spectrum(group.spectra));
  } else {
    group_.assign(group.spectra.begin(), group.spectra.end());
  }
  std::vector<float> windowed_background(samples_);
  tables.windowed_background(mean_spectrum(group_), windowed_background);

  // Candidates spread evenly over the group, as the chain makes their spectra.
  const std::uint64_t total = std::uint64_t{h.bscan_count} * width;
  const auto candidates =
      static_cast<std::uint32_t>(std::min<std::uint64_t>(total, 4ull * search_.ascans));
  std::vector<float> values(samples_);
  std::vector<float> all(std::size_t{candidates} * samples_);
  for (std::uint32_t c = 0; c < candidates; ++c) {
    const std::uint64_t index = std::uint64_t{c} * total / candidates;
    const std::uint16_t* raw = record(static_cast<std::uint32_t>(index / width),
                                      static_cast<std::uint32_t>(index % width));
    for (std::uint32_t s = 0; s < samples_; ++s) values[s] = static_cast<float>(raw[s]);
    float* out = all.data() + std::size_t{c} * samples_;
    for (std::uint32_t j = 0; j < samples_; ++j) {
      out[j] = tables.spectrum_value(values.data(), windowed_background.data(), j);
    }
  }

  // Rows left out: the DC region and the rows whose phase is the same in every A-scan.
  dc_rows_ = search_.dc_rows != 0 ? search_.dc_rows : std::max(8u, samples_ / 64);
  dc_rows_ = std::min(dc_rows_, depth - 1);
  const FftwArray<std::complex<float>> bins = transform(all.data(), candidates, samples_);
  // Random phases give a coherence of about 1 / sqrt(n): stay well above it for few A-scans.
  const double threshold =
      std::max(search_.fixed_coherence, 4.0 / std::sqrt(static_cast<double>(candidates)));
  fixed_rows_.clear();
  // Phase only, so that one bright A-scan cannot make a row look coherent on its own.
  for (std::uint32_t d = dc_rows_; d < depth; ++d) {
    std::complex<double> coherent = 0.0;
    std::uint32_t counted = 0;
    for (std::uint32_t c = 0; c < candidates; ++c) {
      const std::complex<double> x(bins.data()[std::size_t{c} * samples_ + d]);
      const double power = std::norm(x);
      if (power <= 0.0) continue;
      coherent += x * x / power;  // exp(2 i theta): a sign flip keeps the phase
      ++counted;
    }
    if (counted > 0 && std::abs(coherent) > threshold * counted) fixed_rows_.push_back(d);
  }
  kept_ = kept_rows(0);

  // Signal per candidate: its energy in the rows kept; the brightest are used, weighted by
  // their energy above the 10th percentile (about an A-scan without tissue).
  std::vector<std::pair<double, std::uint32_t>> energy(candidates);
  for (std::uint32_t c = 0; c < candidates; ++c) {
    double e = 0.0;
    for (std::uint32_t d = 0; d < depth; ++d) {
      if (kept_[d])
        e += std::norm(std::complex<double>(bins.data()[std::size_t{c} * samples_ + d]));
    }
    energy[c] = {e, c};
  }
  std::vector<double> sorted(candidates);
  std::transform(energy.begin(), energy.end(), sorted.begin(),
                 [](const auto& e) { return e.first; });
  std::nth_element(sorted.begin(), sorted.begin() + candidates / 10, sorted.end());
  const double floor = sorted[candidates / 10];
  ascans_ = std::min(candidates, search_.ascans);
  std::partial_sort(energy.begin(), energy.begin() + ascans_, energy.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  spectra_.resize(std::size_t{ascans_} * samples_);
  weights_.resize(ascans_);
  for (std::uint32_t a = 0; a < ascans_; ++a) {
    std::copy_n(all.data() + std::size_t{energy[a].second} * samples_, samples_,
                spectra_.data() + std::size_t{a} * samples_);
    weights_[a] = std::max(0.0, energy[a].first - floor);
  }
  if (std::accumulate(weights_.begin(), weights_.end(), 0.0) <= 0.0) {
    std::fill(weights_.begin(), weights_.end(), 1.0);  // no signal above the floor: all alike
  }

  // The tissue's median row: the mean intensity per kept row of the A-scans used, less the
  // noise floor (the median over the kept rows: tissue fills fewer than half of them).
  std::vector<double> profile(depth, 0.0);
  for (std::uint32_t a = 0; a < ascans_; ++a) {
    const std::complex<float>* x = bins.data() + std::size_t{energy[a].second} * samples_;
    for (std::uint32_t d = 0; d < depth; ++d) {
      if (kept_[d]) profile[d] += std::norm(std::complex<double>(x[d]));
    }
  }
  std::vector<double> kept_profile;
  for (std::uint32_t d = 0; d < depth; ++d) {
    if (kept_[d]) kept_profile.push_back(profile[d]);
  }
  tissue_median_row_ = 0;
  if (!kept_profile.empty()) {
    std::nth_element(kept_profile.begin(), kept_profile.begin() + kept_profile.size() / 2,
                     kept_profile.end());
    const double noise = kept_profile[kept_profile.size() / 2];
    double total_signal = 0.0;
    for (std::uint32_t d = 0; d < depth; ++d) {
      if (kept_[d]) total_signal += std::max(0.0, profile[d] - noise);
    }
    double running = 0.0;
    for (std::uint32_t d = 0; d < depth && total_signal > 0.0; ++d) {
      if (kept_[d]) running += std::max(0.0, profile[d] - noise);
      if (running >= 0.5 * total_signal) {
        tissue_median_row_ = d;
        break;
      }
    }
  }

  metric_in_ = FftwArray<std::complex<float>>(std::size_t{ascans_} * samples_);
  metric_out_ = FftwArray<std::complex<float>>(std::size_t{ascans_} * samples_);
  FftConfig fft;
  fft.rigor = FftRigor::estimate;  // planning must not cost more than the search
  metric_plan_ =
      FftwC2cPlan(fft, samples_, ascans_, samples_, metric_in_.data(), metric_out_.data());

  geometry_ = geometry;
  header_ = h;
  window_ = tables.window;
  evaluations_ = 0;
}

std::vector<std::uint8_t> DispersionEstimator::kept_rows(std::uint32_t spread) const {
  const std::uint32_t depth = samples_ / 2;
  std::vector<std::uint8_t> kept(depth, 1);
  std::fill_n(kept.begin(), std::min(depth, dc_rows_ + spread), 0);
  const std::uint32_t reach = search_.fixed_margin + spread;
  for (const std::uint32_t row : fixed_rows_) {
    const std::uint32_t begin = row > reach ? row - reach : 0;
    const std::uint32_t end = std::min(depth, row + reach + 1);
    std::fill(kept.begin() + begin, kept.begin() + end, 0);
  }
  return kept;
}

double DispersionEstimator::sharpness(double c2, double c3) {
  if (ascans_ == 0) throw std::logic_error("DispersionEstimator::sharpness before load()");
  return metric(c2, c3, kept_);
}

double DispersionEstimator::metric(double c2, double c3, const std::vector<std::uint8_t>& kept) {
  ++evaluations_;
  const std::vector<std::complex<float>> correction =
      dispersion_correction(DispersionConfig{c2, c3}, samples_);
  std::complex<float>* in = metric_in_.data();
  for (std::size_t i = 0; i < std::size_t{ascans_} * samples_; ++i) {
    const float v = spectra_[i];
    in[i] = correction.empty() ? std::complex<float>(v, 0.0f) : v * correction[i % samples_];
  }
  metric_plan_.execute(metric_in_.data(), metric_out_.data());
  const std::complex<float>* bins = metric_out_.data();
  const std::uint32_t depth = samples_ / 2;
  double metric = 0.0;
  double weight = 0.0;
  for (std::uint32_t a = 0; a < ascans_; ++a) {
    const std::complex<float>* x = bins + std::size_t{a} * samples_;
    double sum = 0.0;
    double sum_squares = 0.0;
    for (std::uint32_t d = 0; d < depth; ++d) {
      if (!kept[d]) continue;
      const double intensity = std::norm(std::complex<double>(x[d]));
      sum += intensity;
      sum_squares += intensity * intensity;
    }
    if (sum > 0.0) {
      metric += weights_[a] * sum_squares / (sum * sum);
      weight += weights_[a];
    }
  }
  return weight > 0.0 ? metric / weight : 0.0;
}

double DispersionEstimator::best_c2(const std::vector<std::uint8_t>& kept, double c2, double c3) {
  constexpr std::uint32_t kPoints = 21;
  const double half_width = std::max(10.0, 0.5 * std::abs(c2));
  double step = 2.0 * half_width / (kPoints - 1);
  double best = c2;
  double best_metric = metric(c2, c3, kept);
  for (std::uint32_t i = 0; i < kPoints; ++i) {
    const double candidate = c2 - half_width + step * i;
    const double m = metric(candidate, c3, kept);
    if (m > best_metric) {
      best_metric = m;
      best = candidate;
    }
  }
  for (step /= 2.0; step >= 0.1; step /= 2.0) {
    for (const double candidate : {best - step, best + step}) {
      const double m = metric(candidate, c3, kept);
      if (m > best_metric) {
        best_metric = m;
        best = candidate;
      }
    }
  }
  return best;
}

void DispersionEstimator::check_depth_consistency(DispersionEstimate& e) {
  if ((e.searched_c2 == 0.0 && e.searched_c3 == 0.0) || tissue_median_row_ == 0) return;
  std::vector<std::uint8_t> shallow = kept_;
  std::vector<std::uint8_t> deep = kept_;
  std::fill(shallow.begin() + tissue_median_row_, shallow.end(), 0);
  std::fill(deep.begin(), deep.begin() + tissue_median_row_, 0);
  e.depth_split = tissue_median_row_;
  e.c2_shallow = best_c2(shallow, e.searched_c2, e.searched_c3);
  e.c2_deep = best_c2(deep, e.searched_c2, e.searched_c3);
  e.depth_dependent =
      std::abs(e.c2_shallow - e.c2_deep) > std::max(3.0, 0.1 * std::abs(e.searched_c2));
}

double DispersionEstimator::processed_sharpness(double c2, double c3, double spread_c2,
                                                double spread_c3) const {
  if (group_.empty())
    throw std::logic_error("DispersionEstimator::processed_sharpness before load()");
  OctProcessorConfig config = processing_;
  config.dispersion = {c2, c3};
  CpuOctProcessor processor(config);
  processor.prepare(geometry_);
  ProcessedGroup out;
  processor.process(RawGroup{header_, group_}, out);
  const std::vector<std::uint8_t> kept =
      kept_rows(chirp_spread_rows(DispersionConfig{spread_c2, spread_c3}, window_));
  return volume_sharpness(out, config.scale, kept);
}

DispersionEstimate DispersionEstimator::estimate() {
  DispersionEstimate result;
  result.sharpness_uncompensated = sharpness(0.0, 0.0);
  double best_c2 = 0.0;
  double best_c3 = 0.0;
  double best = result.sharpness_uncompensated;
  const auto grid = [&](double limit, bool along_c2) {
    const std::uint32_t n = search_.grid_points;
    for (std::uint32_t i = 0; i < n; ++i) {
      const double value = -limit + 2.0 * limit * i / (n - 1);
      const double c2 = along_c2 ? value : best_c2;
      const double c3 = along_c2 ? best_c3 : value;
      const double s = sharpness(c2, c3);
      if (s > best) {
        best = s;
        best_c2 = c2;
        best_c3 = c3;
      }
    }
  };
  if (search_.c2_limit > 0.0) grid(search_.c2_limit, true);
  if (search_.c3_limit > 0.0) grid(search_.c3_limit, false);
  // Coordinate search from the grid's spacing down to the tolerance.
  const double n = search_.grid_points - 1;
  double step2 = search_.c2_limit > 0.0 ? 2.0 * search_.c2_limit / n : 0.0;
  double step3 = search_.c3_limit > 0.0 ? 2.0 * search_.c3_limit / n : 0.0;
  // Within one grid spacing of the grid's best point: a metric without a clear peak (no tissue,
  // only noise) would otherwise let the search wander.
  const double centre2 = best_c2;
  const double centre3 = best_c3;
  const double reach2 = step2 * (1.0 + 1e-9);
  const double reach3 = step3 * (1.0 + 1e-9);
  constexpr std::uint32_t kMaxEvaluations = 5000;  // a bound however the metric behaves
  while (std::max(step2, step3) >= search_.tolerance && evaluations_ < kMaxEvaluations) {
    bool moved = false;
    for (const auto& [d2, d3] : {std::pair{step2, 0.0}, std::pair{-step2, 0.0},
                                 std::pair{0.0, step3}, std::pair{0.0, -step3}}) {
      if (d2 == 0.0 && d3 == 0.0) continue;
      if (std::abs(best_c2 + d2 - centre2) > reach2 || std::abs(best_c3 + d3 - centre3) > reach3) {
        continue;
      }
      const double s = sharpness(best_c2 + d2, best_c3 + d3);
      if (s > best) {
        best = s;
        best_c2 += d2;
        best_c3 += d3;
        moved = true;
      }
    }
    if (!moved) {
      step2 /= 2.0;
      step3 /= 2.0;
    }
  }
  result.searched_c2 = best_c2;
  result.searched_c3 = best_c3;
  result.c2 = best_c2;
  result.c3 = best_c3;
  result.sharpness = best;
  result.ascans_used = ascans_;
  result.evaluations = evaluations_;
  result.dc_rows = dc_rows_;
  result.fixed_pattern_rows = fixed_rows_;
  check_depth_consistency(result);
  result.evaluations = evaluations_;
  if (search_.check_on_chain) check(result);
  return result;
}

void DispersionEstimator::check(DispersionEstimate& e) const {
  const double c2 = e.searched_c2;
  const double c3 = e.searched_c3;
  e.checked = true;
  e.processed_sharpness_uncompensated = processed_sharpness(0.0, 0.0, c2, c3);
  e.processed_sharpness = (c2 == 0.0 && c3 == 0.0) ? e.processed_sharpness_uncompensated
                                                   : processed_sharpness(c2, c3, c2, c3);
  // Measurably sharper, not by rounding (with no tissue left in the rows, both are alike).
  const bool wins = e.processed_sharpness > kMinimumGain * e.processed_sharpness_uncompensated;
  e.rejected = !wins && (c2 != 0.0 || c3 != 0.0);
  e.c2 = wins ? c2 : 0.0;
  e.c3 = wins ? c3 : 0.0;
}

std::string describe_check(const DispersionEstimate& e) {
  char line[400];
  if (!e.checked) return "not checked on the processed volume";
  if (e.rejected) {
    std::snprintf(line, sizeof line,
                  "estimate rejected: the volume processed at c2 = %.3f, c3 = %.3f is not "
                  "sharper than uncompensated (standard sharpness %.5g vs %.5g); no correction "
                  "(c2 = c3 = 0) is the better choice",
                  e.searched_c2, e.searched_c3, e.processed_sharpness,
                  e.processed_sharpness_uncompensated);
  } else if (e.c2 == 0.0 && e.c3 == 0.0) {
    std::snprintf(line, sizeof line,
                  "no correction found sharper than none (standard sharpness %.5g)",
                  e.processed_sharpness_uncompensated);
  } else {
    std::snprintf(line, sizeof line,
                  "estimate kept: the processed volume is sharper with it (standard sharpness "
                  "%.5g, uncompensated %.5g, x%.2f)",
                  e.processed_sharpness, e.processed_sharpness_uncompensated,
                  e.processed_sharpness_uncompensated > 0
                      ? e.processed_sharpness / e.processed_sharpness_uncompensated
                      : 0.0);
  }
  return line;
}

}  // namespace ioct::gpu
