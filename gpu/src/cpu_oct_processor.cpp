#include "ioct/gpu/cpu_oct_processor.hpp"

#include <algorithm>
#include <bit>
#include <numeric>
#include <stdexcept>

#include "ioct/gpu/group_check.hpp"
#include "ioct/gpu/line_flip.hpp"

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

void CpuOctProcessor::prepare(const shm::RingGeometry& geometry) {
  geometry_.reset();  // unprepared until every buffer and plan below exists
  require_processable(geometry);
  const std::uint32_t samples = geometry.samples_per_ascan;
  depth_ = depth_of(geometry);
  // Rows start on 64-byte boundaries, so every row of a batch is as aligned as the first one
  // and the single-transform plan may run on any row of the batch buffers.
  in_distance_ = round_up(samples, 16);
  out_distance_ = round_up(samples / 2 + 1, 8);

  background_.prepare(config_.background, samples, geometry.bscans_per_group,
                      geometry.ascans_per_bscan);
  window_ = make_window(config_.window.kind, samples);
  windowed_background_.assign(samples, 0.0f);
  scale_.emplace(config_.scale, std::accumulate(window_.begin(), window_.end(), 0.0));

  workspaces_.clear();
  for (unsigned t = 0; t < pool_.threads(); ++t) {
    workspaces_.push_back(
        Workspace{FftwArray<float>(std::size_t{kBatchAscans} * in_distance_),
                  FftwArray<std::complex<float>>(std::size_t{kBatchAscans} * out_distance_)});
  }
  Workspace& w = workspaces_.front();
  batch_plan_ = FftwR2cPlan(config_.fft, samples, kBatchAscans, in_distance_, out_distance_,
                            w.spectra.data(), w.bins.data());
  single_plan_ = FftwR2cPlan(config_.fft, samples, 1, in_distance_, out_distance_, w.spectra.data(),
                             w.bins.data());
  geometry_ = geometry;
}

void CpuOctProcessor::process(const RawGroup& group, ProcessedGroup& out) {
  if (!geometry_) throw std::logic_error("CpuOctProcessor::process before prepare()");
  const shm::RingGeometry& g = *geometry_;
  if (auto problem = find_group_problem(group.header, g, group.spectra.size_bytes())) {
    throw std::invalid_argument("group " + std::to_string(group.header.group_index) + ": " +
                                *problem);
  }
  const shm::SlotHeader& h = group.header;
  const std::uint32_t width = h.active_ascan_end - h.active_ascan_begin;
  out.group_index = h.group_index;
  out.producer_epoch = h.producer_epoch;
  out.t_publish_ns = h.t_publish_ns;
  out.bscan_count = h.bscan_count;
  out.ascans = width;
  out.depth = depth_;
  std::copy_n(h.bscans.begin(), h.bscan_count, out.markers.begin());
  out.pixels.resize(std::size_t{h.bscan_count} * width * depth_);

  const std::size_t samples = g.samples_per_ascan;
  const std::uint16_t* first_active = group.spectra.data() + h.active_ascan_begin * samples;
  pool_.run(h.bscan_count, [&](std::uint32_t b, unsigned) {
    background_.accumulate_bscan(b, first_active + std::size_t{b} * g.ascans_per_bscan * samples,
                                 width);
  });
  background_.finish(h.bscan_count, width);
  const std::span<const float> background = background_.background();
  for (std::size_t s = 0; s < samples; ++s) windowed_background_[s] = background[s] * window_[s];

  pool_.run(h.bscan_count, [&](std::uint32_t b, unsigned worker) {
    process_bscan(group, out, b, workspaces_[worker]);
  });
}

void CpuOctProcessor::process_bscan(const RawGroup& group, ProcessedGroup& out, std::uint32_t bscan,
                                    Workspace& workspace) const noexcept {
  const shm::SlotHeader& h = group.header;
  const std::uint32_t samples = geometry_->samples_per_ascan;
  const std::uint32_t width = out.ascans;
  const bool reversed = (h.bscans[bscan].flags & shm::kBscanReversed) != 0;
  const std::uint16_t* records =
      group.spectra.data() +
      (std::size_t{bscan} * geometry_->ascans_per_bscan + h.active_ascan_begin) * samples;
  std::uint8_t* pixels = out.bscan(bscan).data();
  const float* __restrict window = window_.data();
  const float* __restrict windowed_background = windowed_background_.data();
  const std::uint32_t in_distance = in_distance_;
  const std::uint32_t out_distance = out_distance_;
  const std::uint32_t depth = depth_;

  for (std::uint32_t first = 0; first < width; first += kBatchAscans) {
    const std::uint32_t count = std::min(kBatchAscans, width - first);
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint16_t* __restrict raw = records + std::size_t{first + i} * samples;
      float* __restrict spectrum = workspace.spectra.data() + std::size_t{i} * in_distance;
      for (std::uint32_t s = 0; s < samples; ++s) {
        spectrum[s] = static_cast<float>(raw[s]) * window[s] - windowed_background[s];
      }
    }
    if (count == kBatchAscans) {
      batch_plan_.execute(workspace.spectra.data(), workspace.bins.data());
    } else {
      for (std::uint32_t i = 0; i < count; ++i) {
        single_plan_.execute(workspace.spectra.data() + std::size_t{i} * in_distance,
                             workspace.bins.data() + std::size_t{i} * out_distance);
      }
    }
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t column = placed_column(first + i, width, reversed);
      scale_->map_row(workspace.bins.data() + std::size_t{i} * out_distance,
                      pixels + std::size_t{column} * depth, depth);
    }
  }
}

}  // namespace ioct::gpu
