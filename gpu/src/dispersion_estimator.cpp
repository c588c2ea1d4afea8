#include "ioct/gpu/dispersion_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>
#include <stdexcept>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/fftw_c2c_plan.hpp"
#include "ioct/gpu/group_check.hpp"
#include "ioct/gpu/spectral_tables.hpp"

namespace ioct::gpu {

void DispersionSearch::validate() const {
  require_real_in_range("c2_limit", c2_limit, 0.0, 10000.0);
  require_real_in_range("c3_limit", c3_limit, 0.0, 10000.0);
  require_integer_in_range("grid_points", grid_points, 3, 1001);
  require_real_in_range("tolerance", tolerance, 1e-6, 100.0);
  require_integer_in_range("ascans", ascans, 1, 65536);
  require_integer_in_range("skip_depth", skip_depth, 0, 1024);
}

DispersionEstimator::DispersionEstimator(const OctProcessorConfig& processing,
                                         const DispersionSearch& search)
    : processing_(processing), search_(search) {
  processing_.dispersion = {};
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
  const SpectralTables tables = make_spectral_tables(processing_, samples_);
  const std::uint32_t width = h.active_ascan_end - h.active_ascan_begin;
  const auto record = [&](std::uint32_t b, std::uint32_t a) {
    return group.spectra.data() +
           (std::size_t{b} * geometry.ascans_per_bscan + h.active_ascan_begin + a) * samples_;
  };

  // The group's mean spectrum as the background (one group: there is no history here).
  BackgroundConfig background = processing_.background;
  background.groups = 1;
  CpuBackgroundEstimator estimator;
  estimator.prepare(background, samples_, geometry.bscans_per_group, geometry.ascans_per_bscan);
  for (std::uint32_t b = 0; b < h.bscan_count; ++b)
    estimator.accumulate_bscan(b, record(b, 0), width);
  estimator.finish(h.bscan_count, width);
  std::vector<float> windowed_background(samples_);
  tables.windowed_background(estimator.background(), windowed_background);

  // Candidates spread evenly over the group; the brightest of them are kept.
  const std::uint64_t total = std::uint64_t{h.bscan_count} * width;
  const std::uint64_t candidates = std::min<std::uint64_t>(total, 4ull * search_.ascans);
  std::vector<float> values(samples_);
  std::vector<float> all(candidates * samples_);
  std::vector<std::pair<double, std::uint64_t>> energy(candidates);
  for (std::uint64_t c = 0; c < candidates; ++c) {
    const std::uint64_t index = c * total / candidates;
    const std::uint16_t* raw = record(static_cast<std::uint32_t>(index / width),
                                      static_cast<std::uint32_t>(index % width));
    for (std::uint32_t s = 0; s < samples_; ++s) values[s] = static_cast<float>(raw[s]);
    double e = 0.0;
    float* out = all.data() + c * samples_;
    for (std::uint32_t j = 0; j < samples_; ++j) {
      out[j] = tables.resampled(values.data(), j) * tables.window[j] - windowed_background[j];
      e += double{out[j]} * out[j];
    }
    energy[c] = {e, c};
  }
  ascans_ = static_cast<std::uint32_t>(std::min<std::uint64_t>(candidates, search_.ascans));
  std::partial_sort(energy.begin(), energy.begin() + ascans_, energy.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  spectra_.resize(std::size_t{ascans_} * samples_);
  for (std::uint32_t a = 0; a < ascans_; ++a) {
    std::copy_n(all.data() + energy[a].second * samples_, samples_,
                spectra_.data() + std::size_t{a} * samples_);
  }
  evaluations_ = 0;
}

double DispersionEstimator::sharpness(double c2, double c3) {
  if (ascans_ == 0) throw std::logic_error("DispersionEstimator::sharpness before load()");
  ++evaluations_;
  const std::vector<std::complex<float>> correction =
      dispersion_correction(DispersionConfig{c2, c3}, samples_);
  FftwArray<std::complex<float>> in(std::size_t{ascans_} * samples_);
  FftwArray<std::complex<float>> out(std::size_t{ascans_} * samples_);
  for (std::uint32_t a = 0; a < ascans_; ++a) {
    const float* v = spectra_.data() + std::size_t{a} * samples_;
    std::complex<float>* s = in.data() + std::size_t{a} * samples_;
    for (std::uint32_t j = 0; j < samples_; ++j) {
      s[j] = correction.empty() ? std::complex<float>(v[j], 0.0f) : v[j] * correction[j];
    }
  }
  // Planned per call with FFTW_ESTIMATE: cheap next to the transforms.
  FftConfig fft;
  fft.rigor = FftRigor::estimate;
  const FftwC2cPlan plan(fft, samples_, ascans_, samples_, in.data(), out.data());
  plan.execute(in.data(), out.data());
  const std::uint32_t depth = samples_ / 2;
  double metric = 0.0;
  for (std::uint32_t a = 0; a < ascans_; ++a) {
    const std::complex<float>* x = out.data() + std::size_t{a} * samples_;
    double sum = 0.0;
    double sum_squares = 0.0;
    for (std::uint32_t d = std::min(search_.skip_depth, depth - 1); d < depth; ++d) {
      const double intensity = std::norm(std::complex<double>(x[d]));
      sum += intensity;
      sum_squares += intensity * intensity;
    }
    if (sum > 0.0) metric += sum_squares / (sum * sum);
  }
  return metric / ascans_;
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
  constexpr std::uint32_t kMaxEvaluations = 5000;  // a bound however the metric behaves
  while (std::max(step2, step3) >= search_.tolerance && evaluations_ < kMaxEvaluations) {
    bool moved = false;
    for (const auto& [d2, d3] : {std::pair{step2, 0.0}, std::pair{-step2, 0.0},
                                 std::pair{0.0, step3}, std::pair{0.0, -step3}}) {
      if (d2 == 0.0 && d3 == 0.0) continue;
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
  result.c2 = best_c2;
  result.c3 = best_c3;
  result.sharpness = best;
  result.ascans_used = ascans_;
  result.evaluations = evaluations_;
  return result;
}

}  // namespace ioct::gpu
