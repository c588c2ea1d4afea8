#include "ioct/sim/spectral_sampling.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace ioct::sim {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Least-squares polynomial of `degree` through (t, x) by the normal equations on t in [0, 1]
// rescaled to [-1, 1] (well conditioned at degree 7), returned in powers of t.
std::vector<double> fit_polynomial(const std::vector<double>& t, const std::vector<double>& x,
                                   std::uint32_t degree) {
  const std::size_t terms = degree + 1;
  std::vector<double> normal(terms * terms, 0.0);
  std::vector<double> rhs(terms, 0.0);
  std::vector<double> powers(2 * terms);
  for (std::size_t n = 0; n < t.size(); ++n) {
    const double u = 2.0 * t[n] - 1.0;
    powers[0] = 1.0;
    for (std::size_t p = 1; p < powers.size(); ++p) powers[p] = powers[p - 1] * u;
    for (std::size_t r = 0; r < terms; ++r) {
      rhs[r] += powers[r] * x[n];
      for (std::size_t c = 0; c < terms; ++c) normal[r * terms + c] += powers[r + c];
    }
  }
  // Gaussian elimination with partial pivoting.
  for (std::size_t col = 0; col < terms; ++col) {
    std::size_t pivot = col;
    for (std::size_t r = col + 1; r < terms; ++r) {
      if (std::abs(normal[r * terms + col]) > std::abs(normal[pivot * terms + col])) pivot = r;
    }
    for (std::size_t c = 0; c < terms; ++c) {
      std::swap(normal[col * terms + c], normal[pivot * terms + c]);
    }
    std::swap(rhs[col], rhs[pivot]);
    for (std::size_t r = col + 1; r < terms; ++r) {
      const double f = normal[r * terms + col] / normal[col * terms + col];
      for (std::size_t c = col; c < terms; ++c)
        normal[r * terms + c] -= f * normal[col * terms + c];
      rhs[r] -= f * rhs[col];
    }
  }
  std::vector<double> in_u(terms);
  for (std::size_t r = terms; r-- > 0;) {
    double sum = rhs[r];
    for (std::size_t c = r + 1; c < terms; ++c) sum -= normal[r * terms + c] * in_u[c];
    in_u[r] = sum / normal[r * terms + r];
  }
  // u = 2 t - 1: expand sum a_p (2t - 1)^p into powers of t.
  std::vector<double> in_t(terms, 0.0);
  std::vector<double> binomial_row{1.0};  // coefficients of (2t - 1)^p in powers of t
  for (std::size_t p = 0; p < terms; ++p) {
    for (std::size_t q = 0; q < binomial_row.size(); ++q) in_t[q] += in_u[p] * binomial_row[q];
    std::vector<double> next(binomial_row.size() + 1, 0.0);
    for (std::size_t q = 0; q < binomial_row.size(); ++q) {
      next[q] -= binomial_row[q];
      next[q + 1] += 2.0 * binomial_row[q];
    }
    binomial_row = std::move(next);
  }
  return in_t;
}

}  // namespace

double KCalibration::raw_position(std::uint32_t samples, double j) const noexcept {
  const double last = static_cast<double>(samples - 1);
  const double t = j / last;
  double value = 0.0;
  for (std::size_t i = coefficients.size(); i-- > 0;) value = value * t + coefficients[i];
  return last * value;
}

SpectralSampling spectral_sampling(const SweptSourceConfig& source, hal::ClockSource clock,
                                   std::uint32_t samples) {
  SpectralSampling sampling;
  const double n = static_cast<double>(samples);
  const double last = n - 1.0;
  const double k_step = (source.k_max() - source.k_min()) / n;
  sampling.calibration.k_first_rad_per_um = source.k_min();
  sampling.calibration.k_step_rad_per_um = k_step;
  sampling.k_index.resize(samples);
  sampling.wavelength_nm.resize(samples);
  if (clock == hal::ClockSource::external_k_clock) {
    for (std::uint32_t i = 0; i < samples; ++i) {
      sampling.k_index[i] = i;
      sampling.wavelength_nm[i] = kTwoPi / (source.k_min() + i * k_step) * 1e3;
    }
    sampling.calibration.coefficients = {0.0, 1.0};
    sampling.k_linear = true;
    return sampling;
  }
  // Linear in wavelength between the k-linear grid's first and last points.
  const double k_first = source.k_min();
  const double k_last = source.k_min() + last * k_step;
  const double lambda_first = kTwoPi / k_first;
  const double lambda_last = kTwoPi / k_last;
  for (std::uint32_t i = 0; i < samples; ++i) {
    const double lambda = lambda_first + (lambda_last - lambda_first) * (i / last);
    sampling.wavelength_nm[i] = lambda * 1e3;
    sampling.k_index[i] = (kTwoPi / lambda - k_first) / k_step;
  }
  // Exact inverse: the raw position of k-linear sample j, as a fraction of the sweep.
  std::vector<double> t(samples);
  std::vector<double> x(samples);
  for (std::uint32_t j = 0; j < samples; ++j) {
    const double lambda = kTwoPi / (k_first + j * k_step);
    t[j] = j / last;
    x[j] = (lambda_first - lambda) / (lambda_first - lambda_last);
  }
  sampling.calibration.coefficients = fit_polynomial(t, x, kCalibrationDegree);
  double worst = 0.0;
  for (std::uint32_t j = 0; j < samples; ++j) {
    worst = std::max(worst, std::abs(sampling.calibration.raw_position(samples, j) - last * x[j]));
  }
  sampling.calibration.max_error_samples = worst;
  sampling.k_linear = false;
  return sampling;
}

}  // namespace ioct::sim
