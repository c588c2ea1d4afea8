#include "ioct/gpu/processing/spectral_tables.hpp"

#include <numeric>

namespace ioct::gpu {
namespace {

double window_sum(const std::vector<float>& window) {
  return std::accumulate(window.begin(), window.end(), 0.0);
}

}  // namespace

SpectralTables make_spectral_tables(const OctProcessorConfig& config, std::uint32_t samples) {
  std::vector<float> window = make_window(config.window.kind, samples);
  const double sum = window_sum(window);
  return SpectralTables{samples,
                        samples / 2,
                        std::move(window),
                        make_resampling_table(config.resampling, samples),
                        dispersion_correction(config.dispersion, samples),
                        DbToU8(config.scale, sum)};
}

void SpectralTables::set_db_range(const DbScaleConfig& config) {
  scale = DbToU8(config, window_sum(window));
}

void SpectralTables::windowed_background(std::span<const float> background,
                                         std::span<float> out) const {
  for (std::uint32_t j = 0; j < samples; ++j) out[j] = resampled(background.data(), j) * window[j];
}

}  // namespace ioct::gpu
