#include "surface_errors.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace ioct::seg_test {

std::string SurfaceErrors::describe() const {
  char text[224];
  std::snprintf(text, sizeof text,
                "%zu A-scans: mean |error| %.3f px, median %.3f, p99 %.2f, max %.2f (A-scan %zu), "
                "%zu missing",
                compared, mean_absolute, median, p99, max, worst, missing);
  return text;
}

SurfaceErrors surface_errors(std::span<const float> surface, std::span<const float> reference,
                             const std::vector<bool>* include) {
  if (surface.size() != reference.size()) {
    throw std::invalid_argument("surface_errors: sizes differ");
  }
  SurfaceErrors e;
  std::vector<double> errors;
  for (std::size_t i = 0; i < surface.size(); ++i) {
    if (!std::isfinite(reference[i]) || (include != nullptr && !(*include)[i])) continue;
    if (!std::isfinite(surface[i])) {
      ++e.missing;
      continue;
    }
    const double error = std::fabs(static_cast<double>(surface[i]) - reference[i]);
    if (errors.empty() || error > e.max) {
      e.max = error;
      e.worst = i;
    }
    errors.push_back(error);
  }
  e.compared = errors.size();
  if (errors.empty()) return e;
  double sum = 0.0;
  for (const double x : errors) sum += x;
  e.mean_absolute = sum / static_cast<double>(errors.size());
  std::sort(errors.begin(), errors.end());
  const auto at = [&](double q) {
    const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(errors.size())));
    return errors[std::min(errors.size() - 1, rank > 0 ? rank - 1 : 0)];
  };
  e.p99 = at(0.99);
  e.median = at(0.5);
  return e;
}

}  // namespace ioct::seg_test
