#include "ioct/gpu/processing/cpu_oct_processor.hpp"

#include <algorithm>
#include <bit>
#include <stdexcept>

#include "ioct/gpu/processing/group_check.hpp"
#include "ioct/gpu/processing/line_flip.hpp"
#include "ioct/gpu/processing/repeats.hpp"

namespace ioct::gpu {
namespace {

static_assert(std::endian::native == std::endian::little,
              "spectra in the ring are little-endian u16 and are read in place");

std::uint32_t round_up(std::uint32_t value, std::uint32_t multiple) {
  return (value + multiple - 1) / multiple * multiple;
}

}  // namespace

CpuOctProcessor::CpuOctProcessor(const OctProcessorConfig& config)
    : config_((config.validate(), config)), pool_(config.threads) {}

void CpuOctProcessor::set_db_range(const DbScaleConfig& scale) {
  scale.validate();
  if (tables_) tables_->set_db_range(scale);
  config_.scale = scale;
}

void CpuOctProcessor::prepare(const shm::RingGeometry& geometry) {
  geometry_.reset();  // unprepared until every buffer and plan below exists
  require_processable(geometry);
  config_.validate_for(geometry);
  const std::uint32_t samples = geometry.samples_per_ascan;
  tables_.emplace(make_spectral_tables(config_, samples));
  depth_ = tables_->depth;
  // Rows start on 64-byte boundaries, so every row of a batch is as aligned as the first one
  // and the single-transform plan may run on any row of the batch buffers.
  const bool complex_fft = tables_->complex_fft();
  in_distance_ = complex_fft ? round_up(samples, 8) : round_up(samples, 16);
  out_distance_ = complex_fft ? in_distance_ : round_up(samples / 2 + 1, 8);

  background_.prepare(config_.background, samples, geometry.bscans_per_group,
                      geometry.ascans_per_bscan);
  windowed_background_.assign(samples, 0.0f);

  workspaces_.clear();
  const std::size_t batch_in = std::size_t{kBatchAscans} * in_distance_;
  const std::size_t batch_out = std::size_t{kBatchAscans} * out_distance_;
  for (unsigned t = 0; t < pool_.threads(); ++t) {
    Workspace w;
    if (complex_fft) {
      w.complex_spectra = FftwArray<std::complex<float>>(batch_in);
    } else {
      w.spectra = FftwArray<float>(batch_in);
    }
    w.bins = FftwArray<std::complex<float>>(batch_out);
    if (tables_->resampling.taps > 0) w.raw.assign(samples, 0.0f);
    if (config_.repeats_per_position > 1) {
      w.power.assign(std::size_t{geometry.ascans_per_bscan} * depth_, 0.0f);
    }
    workspaces_.push_back(std::move(w));
  }
  Workspace& w = workspaces_.front();
  if (complex_fft) {
    complex_batch_plan_ = FftwC2cPlan(config_.fft, samples, kBatchAscans, in_distance_,
                                      w.complex_spectra.data(), w.bins.data());
    complex_single_plan_ =
        FftwC2cPlan(config_.fft, samples, 1, in_distance_, w.complex_spectra.data(), w.bins.data());
  } else {
    batch_plan_ = FftwR2cPlan(config_.fft, samples, kBatchAscans, in_distance_, out_distance_,
                              w.spectra.data(), w.bins.data());
    single_plan_ = FftwR2cPlan(config_.fft, samples, 1, in_distance_, out_distance_,
                               w.spectra.data(), w.bins.data());
  }
  geometry_ = geometry;
}

void CpuOctProcessor::process(const RawGroup& group, ProcessedGroup& out) {
  if (!geometry_) throw std::logic_error("CpuOctProcessor::process before prepare()");
  const shm::RingGeometry& g = *geometry_;
  const std::uint32_t repeats = config_.repeats_per_position;
  if (auto problem = find_group_problem(group.header, g, group.spectra.size_bytes(), repeats)) {
    throw std::invalid_argument("group " + std::to_string(group.header.group_index) + ": " +
                                *problem);
  }
  const shm::SlotHeader& h = group.header;
  const std::uint32_t width = h.active_ascan_end - h.active_ascan_begin;
  out.group_index = h.group_index;
  out.producer_epoch = h.producer_epoch;
  out.t_publish_ns = h.t_publish_ns;
  out.bscan_count = h.bscan_count / repeats;
  out.ascans = width;
  out.depth = depth_;
  for (std::uint32_t p = 0; p < out.bscan_count; ++p)
    out.markers[p] = position_marker(h, p, repeats);
  out.pixels.resize(std::size_t{out.bscan_count} * width * depth_);

  const std::size_t samples = g.samples_per_ascan;
  const std::uint16_t* first_active = group.spectra.data() + h.active_ascan_begin * samples;
  pool_.run(h.bscan_count, [&](std::uint32_t b, unsigned) {
    background_.accumulate_bscan(b, first_active + std::size_t{b} * g.ascans_per_bscan * samples,
                                 width);
  });
  background_.finish(h.bscan_count, width);
  tables_->windowed_background(background_.background(), windowed_background_);

  pool_.run(out.bscan_count, [&](std::uint32_t p, unsigned worker) {
    process_position(group, out, p, workspaces_[worker]);
  });
}

void CpuOctProcessor::make_spectrum(const std::uint16_t* raw, std::uint32_t row,
                                    Workspace& workspace) const noexcept {
  const SpectralTables& tables = *tables_;
  const std::uint32_t samples = tables.samples;
  const float* __restrict window = tables.window.data();
  const float* __restrict windowed_background = windowed_background_.data();
  if (tables.resampling.taps == 0 && !tables.complex_fft()) {
    // The default (k-clock) path, kept to one vectorised pass.
    const std::uint16_t* __restrict in = raw;
    float* __restrict spectrum = workspace.spectra.data() + std::size_t{row} * in_distance_;
    for (std::uint32_t s = 0; s < samples; ++s) {
      spectrum[s] = static_cast<float>(in[s]) * window[s] - windowed_background[s];
    }
    return;
  }
  const float* values = nullptr;
  if (tables.resampling.taps > 0) {
    float* __restrict converted = workspace.raw.data();
    for (std::uint32_t s = 0; s < samples; ++s) converted[s] = static_cast<float>(raw[s]);
    values = converted;
  }
  const auto value_at = [&](std::uint32_t j) {
    if (values != nullptr) return tables.spectrum_value(values, windowed_background, j);
    return static_cast<float>(raw[j]) * window[j] - windowed_background[j];
  };
  if (tables.complex_fft()) {
    std::complex<float>* spectrum =
        workspace.complex_spectra.data() + std::size_t{row} * in_distance_;
    const std::complex<float>* correction = tables.correction.data();
    for (std::uint32_t j = 0; j < samples; ++j) {
      const float v = value_at(j);
      spectrum[j] = {v * correction[j].real(), v * correction[j].imag()};
    }
  } else {
    float* spectrum = workspace.spectra.data() + std::size_t{row} * in_distance_;
    for (std::uint32_t j = 0; j < samples; ++j) spectrum[j] = value_at(j);
  }
}

void CpuOctProcessor::transform_batch(std::uint32_t count, Workspace& workspace) const noexcept {
  if (tables_->complex_fft()) {
    if (count == kBatchAscans) {
      complex_batch_plan_.execute(workspace.complex_spectra.data(), workspace.bins.data());
      return;
    }
    for (std::uint32_t i = 0; i < count; ++i) {
      complex_single_plan_.execute(workspace.complex_spectra.data() + std::size_t{i} * in_distance_,
                                   workspace.bins.data() + std::size_t{i} * out_distance_);
    }
    return;
  }
  if (count == kBatchAscans) {
    batch_plan_.execute(workspace.spectra.data(), workspace.bins.data());
    return;
  }
  for (std::uint32_t i = 0; i < count; ++i) {
    single_plan_.execute(workspace.spectra.data() + std::size_t{i} * in_distance_,
                         workspace.bins.data() + std::size_t{i} * out_distance_);
  }
}

void CpuOctProcessor::process_position(const RawGroup& group, ProcessedGroup& out,
                                       std::uint32_t position,
                                       Workspace& workspace) const noexcept {
  const shm::SlotHeader& h = group.header;
  const std::uint32_t samples = geometry_->samples_per_ascan;
  const std::uint32_t width = out.ascans;
  const std::uint32_t depth = depth_;
  const std::uint32_t repeats = config_.repeats_per_position;
  const DbToU8& scale = tables_->scale;
  std::uint8_t* pixels = out.bscan(position).data();
  float* power = workspace.power.data();
  if (repeats > 1) std::fill_n(power, std::size_t{width} * depth, 0.0f);

  for (std::uint32_t first = 0; first < width; first += kBatchAscans) {
    const std::uint32_t count = std::min(kBatchAscans, width - first);
    for (std::uint32_t r = 0; r < repeats; ++r) {
      const std::uint32_t bscan = position * repeats + r;
      const bool reversed = (h.bscans[bscan].flags & shm::kBscanReversed) != 0;
      const std::uint16_t* records =
          group.spectra.data() +
          (std::size_t{bscan} * geometry_->ascans_per_bscan + h.active_ascan_begin) * samples;
      for (std::uint32_t i = 0; i < count; ++i) {
        make_spectrum(records + std::size_t{first + i} * samples, i, workspace);
      }
      transform_batch(count, workspace);
      for (std::uint32_t i = 0; i < count; ++i) {
        const std::uint32_t column = placed_column(first + i, width, reversed);
        const std::complex<float>* bins = workspace.bins.data() + std::size_t{i} * out_distance_;
        if (repeats == 1) {
          scale.map_row(bins, pixels + std::size_t{column} * depth, depth);
          continue;
        }
        const float* __restrict re_im = reinterpret_cast<const float*>(bins);
        float* __restrict sum = power + std::size_t{column} * depth;
        for (std::uint32_t d = 0; d < depth; ++d) {
          const float re = re_im[2 * d];
          const float im = re_im[2 * d + 1];
          sum[d] += re * re + im * im;
        }
      }
    }
  }
  if (repeats == 1) return;
  const float count = static_cast<float>(repeats);
  for (std::size_t i = 0; i < std::size_t{width} * depth; ++i) power[i] = power[i] / count;
  for (std::uint32_t column = 0; column < width; ++column) {
    scale.map_power_row(power + std::size_t{column} * depth, pixels + std::size_t{column} * depth,
                        depth);
  }
}

}  // namespace ioct::gpu
