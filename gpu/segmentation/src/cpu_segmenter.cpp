#include "ioct/gpu/segmentation/cpu_segmenter.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "ioct/gpu/segmentation/column_math.hpp"
#include "ioct/gpu/segmentation/finishing.hpp"
#include "ioct/gpu/segmentation/histogram.hpp"
#include "ioct/gpu/segmentation/lifted_rpe.hpp"

namespace ioct::gpu::segmentation {

using detail::kUnreachable;

void solve_path(std::int32_t ascans, std::int32_t states, const std::int32_t* origin,
                const std::int32_t* cost, std::int32_t max_step, std::int32_t penalty,
                std::int32_t* path, std::vector<std::int32_t>& forward,
                std::vector<std::int32_t>& backward, std::vector<std::int32_t>& next,
                std::vector<std::int8_t>& steps) {
  const std::size_t s_count = static_cast<std::size_t>(states);
  forward.resize(s_count);
  backward.resize(s_count);
  next.resize(s_count);
  steps.resize(static_cast<std::size_t>(ascans) * s_count);
  const std::int32_t middle = ascans / 2;

  // From the left to the middle column.
  std::copy_n(cost, s_count, forward.begin());
  for (std::int32_t a = 1; a <= middle; ++a) {
    const std::int32_t shift = origin[a] - origin[a - 1];
    const std::int32_t* c = cost + a * s_count;
    for (std::int32_t s = 0; s < states; ++s) {
      int step = 0;
      const std::int32_t best =
          detail::best_step(forward.data(), states, s, shift, max_step, penalty, &step);
      next[s] = detail::add_cost(best, c[s]);
      steps[a * s_count + s] = static_cast<std::int8_t>(step);
    }
    forward.swap(next);
  }
  // From the right to the middle column.
  std::copy_n(cost + (ascans - 1) * s_count, s_count, backward.begin());
  for (std::int32_t a = ascans - 2; a >= middle; --a) {
    const std::int32_t shift = origin[a] - origin[a + 1];
    const std::int32_t* c = cost + a * s_count;
    for (std::int32_t s = 0; s < states; ++s) {
      int step = 0;
      const std::int32_t best =
          detail::best_step(backward.data(), states, s, shift, max_step, penalty, &step);
      next[s] = detail::add_cost(best, c[s]);
      // Kept at a + 1: the middle column's step from the left is at a.
      steps[(a + 1) * s_count + s] = static_cast<std::int8_t>(step);
    }
    backward.swap(next);
  }
  // Joined in the middle: the state of least total (the first of equals).
  std::int32_t best_state = 0;
  std::int32_t best_total = kUnreachable;
  const std::int32_t* c = cost + middle * s_count;
  for (std::int32_t s = 0; s < states; ++s) {
    if (forward[s] >= kUnreachable || backward[s] >= kUnreachable) continue;
    const std::int32_t total = forward[s] + backward[s] - c[s];
    if (total < best_total) {
      best_total = total;
      best_state = s;
    }
  }
  // Back along the steps taken, to both ends.
  std::int32_t s = best_state;
  path[middle] = origin[middle] + s;
  for (std::int32_t a = middle; a >= 1; --a) {
    s = detail::state_before(s, origin[a] - origin[a - 1], steps[a * s_count + s], states);
    path[a - 1] = origin[a - 1] + s;
  }
  s = best_state;
  for (std::int32_t a = middle; a <= ascans - 2; ++a) {
    s = detail::state_before(s, origin[a] - origin[a + 1], steps[(a + 1) * s_count + s], states);
    path[a + 1] = origin[a + 1] + s;
  }
}

CpuSegmenter::CpuSegmenter(const SegmentationConfig& config, const VolumeSampling& sampling,
                           unsigned threads)
    : config_((config.validate(), config)),
      sampling_((sampling.validate(), sampling)),
      pool_(threads),
      workspaces_(pool_.threads()) {}

BscanSpan CpuSegmenter::segment_group(const Volume& volume, BscanSpan group, Surfaces& surfaces) {
  check_group_request(volume, group);
  params_ = make_params(config_, sampling_, volume.depth(), volume.ascans());
  if (!memory_.fits(volume.bscans(), volume.ascans(), volume.depth()) ||
      surfaces.bscans != volume.bscans() || surfaces.ascans != volume.ascans() ||
      surfaces.depth != volume.depth()) {
    memory_.reset(volume.bscans(), volume.ascans(), volume.depth());
    surfaces.reset(volume.bscans(), volume.ascans(), volume.depth());
  }
  detail::advance_cycle(memory_.clock, static_cast<int>(group.first));
  // Every coarse search of the group first: each fine search takes its neighbours' as a prior.
  pool_.run(group.count, [&](std::uint32_t i, unsigned worker) {
    coarse_bscan(volume, group.first + i, workspaces_[worker]);
  });
  for (std::uint32_t b = group.first; b < group.end(); ++b) memory_.coarse_valid[b] = 1;
  pool_.run(group.count, [&](std::uint32_t i, unsigned worker) {
    fine_bscan(volume, group.first + i, workspaces_[worker]);
  });

  const BscanSpan outputs = outputs_affected(group, volume.bscans());
  measured_.resize(static_cast<std::size_t>(memory_.bscans) * memory_.ascans);
  const detail::RawFits raw{memory_.ilm.data(),
                            memory_.rpe.data(),
                            memory_.bm.data(),
                            memory_.confidence.data(),
                            memory_.verdict.data(),
                            measured_.data(),
                            static_cast<int>(memory_.bscans),
                            static_cast<int>(memory_.ascans)};
  const detail::FinishSettings settings{params_.min_confidence,
                                        params_.smooth_tolerance_px,
                                        static_cast<float>(sampling_.ascan_spacing_um),
                                        static_cast<float>(sampling_.bscan_spacing_um),
                                        params_.bridge_bscans,
                                        params_.smooth};
  // The measured flags the finishing reads, first.
  const detail::MeasuredSpan read =
      detail::measured_span(settings, static_cast<int>(outputs.first),
                            static_cast<int>(outputs.end()), static_cast<int>(memory_.bscans));
  pool_.run(static_cast<std::uint32_t>(read.end - read.first), [&](std::uint32_t i, unsigned) {
    const int b = read.first + static_cast<int>(i);
    for (int a = 0; a < raw.ascans; ++a) {
      measured_[static_cast<std::size_t>(b) * memory_.ascans + a] =
          detail::measured_from_fits(raw, settings, b, a) ? 1 : 0;
    }
  });
  const detail::RememberedFits remembered = memory_.remembered();
  const detail::MembraneSettings membrane =
      detail::membrane_settings(sampling_.ascan_spacing_um, sampling_.axial_um_per_px);
  pool_.run(outputs.count, [&](std::uint32_t i, unsigned worker) {
    const std::uint32_t b = outputs.first + i;
    surfaces.verdict[b] = static_cast<BscanVerdict>(memory_.verdict[b]);
    for (std::uint32_t a = 0; a < volume.ascans(); ++a) {
      const detail::FinishedAscan f =
          detail::finish_ascan(raw, remembered, settings, static_cast<int>(b), static_cast<int>(a));
      const std::size_t k = surfaces.index(b, a);
      surfaces.ilm[k] = f.ilm;
      surfaces.rpe[k] = f.rpe;
      surfaces.bm[k] = f.bm;
      surfaces.confidence[k] = f.confidence;
      surfaces.state[k] = f.state;
      memory_.finished_ilm[k] = f.ilm;
      memory_.finished_rpe[k] = f.rpe;
      memory_.finished_bm[k] = f.bm;
      memory_.finished_kind[k] = f.kind;
    }
    const std::size_t row = surfaces.index(b, 0);
    membrane_bscan(memory_.finished_bm.data() + row, membrane, surfaces.bm.data() + row,
                   workspaces_[worker]);
  });
  return outputs;
}

void CpuSegmenter::membrane_bscan(const float* finished_bm,
                                  const detail::MembraneSettings& settings, float* bm,
                                  Workspace& w) const {
  const std::size_t n = static_cast<std::size_t>(params_.ascans);
  w.smoothed_bm.resize(n);
  w.bm_floor.resize(n);
  w.next_floor.resize(n);
  detail::membrane_of_bscan(finished_bm, params_.ascans, settings, bm, w.smoothed_bm.data(),
                            w.bm_floor.data(), w.next_floor.data());
}

void CpuSegmenter::coarse_bscan(const Volume& volume, std::uint32_t bscan, Workspace& w) {
  const SegmentationParams& p = params_;
  const std::span<const std::uint8_t> pixels = volume.bscan(bscan);
  std::array<std::uint32_t, detail::kHistogramBins> histogram{};
  std::uint32_t sampled = 0;
  for (std::size_t i = 0; i < pixels.size(); i += detail::kFloorSampleStride) {
    ++histogram[pixels[i]];
    ++sampled;
  }
  const int floor = detail::histogram_quantile(histogram.data(), sampled, detail::kFloorNumerator,
                                               detail::kFloorDenominator);
  memory_.floor[bscan] = static_cast<std::uint8_t>(floor);

  // Cell levels of every column, then the cost of each pair of columns: its better column's.
  const std::size_t cells = static_cast<std::size_t>(p.coarse_cells);
  w.levels.resize(static_cast<std::size_t>(p.ascans) * cells);
  for (std::int32_t a = 0; a < p.ascans; ++a) {
    const std::uint8_t* column = pixels.data() + static_cast<std::size_t>(a) * p.depth;
    for (std::int32_t c = 0; c < p.coarse_cells; ++c) {
      w.levels[a * cells + c] = static_cast<std::uint8_t>(detail::cell_level(column, p.depth, c));
    }
  }
  w.cost.resize(static_cast<std::size_t>(p.coarse_columns) * cells);
  w.origin.assign(static_cast<std::size_t>(p.coarse_columns), 0);
  w.path.resize(static_cast<std::size_t>(p.coarse_columns));
  for (std::int32_t q = 0; q < p.coarse_columns; ++q) {
    for (std::int32_t c = 0; c < p.coarse_cells; ++c) {
      std::int32_t cost = detail::kOutsideCost;
      for (std::int32_t a = q * kCoarsePair; a < std::min(p.ascans, (q + 1) * kCoarsePair); ++a) {
        cost =
            std::min(cost, -detail::coarse_score(w.levels.data() + a * cells, p.coarse_cells, c));
      }
      w.cost[q * cells + c] = cost;
    }
  }
  solve_path(p.coarse_columns, p.coarse_cells, w.origin.data(), w.cost.data(), p.coarse_step,
             p.coarse_step_penalty, w.path.data(), w.forward, w.backward, w.next, w.steps);
  std::int32_t* coarse = memory_.coarse.data() + static_cast<std::ptrdiff_t>(bscan) * p.ascans;
  for (std::int32_t a = 0; a < p.ascans; ++a) coarse[a] = w.path[a / kCoarsePair];
}

void CpuSegmenter::fine_bscan(const Volume& volume, std::uint32_t bscan, Workspace& w) {
  const SegmentationParams& p = params_;
  const std::span<const std::uint8_t> pixels = volume.bscan(bscan);
  const int floor = memory_.floor[bscan];
  const std::size_t ascans = static_cast<std::size_t>(p.ascans);
  const std::size_t band = static_cast<std::size_t>(p.band);
  const auto column = [&](std::int32_t a) {
    return pixels.data() + static_cast<std::size_t>(a) * p.depth;
  };

  // The prior: per A-scan the median of this B-scan's coarse RPE and its neighbours'.
  const std::int32_t* own = memory_.coarse.data() + bscan * ascans;
  const bool has_before = bscan > 0 && memory_.coarse_valid[bscan - 1] != 0;
  const bool has_after = bscan + 1 < memory_.bscans && memory_.coarse_valid[bscan + 1] != 0;
  const std::int32_t* before = has_before ? own - ascans : own;
  const std::int32_t* after = has_after ? own + ascans : own;

  // ILM in the band above the prior.
  w.origin.resize(ascans);
  w.cost.resize(ascans * band);
  w.path.resize(ascans);
  w.ilm_px.resize(ascans);
  for (std::int32_t a = 0; a < p.ascans; ++a) {
    const std::int32_t cell = detail::median3(before[a], own[a], after[a]);
    w.origin[a] = detail::ilm_band_origin(cell, p.band);
    for (std::int32_t s = 0; s < p.band; ++s) {
      w.cost[a * band + s] = detail::ilm_cost(column(a), p.depth, w.origin[a] + s, floor);
    }
  }
  solve_path(p.ascans, p.band, w.origin.data(), w.cost.data(), p.max_step, p.step_penalty,
             w.ilm_px.data(), w.forward, w.backward, w.next, w.steps);

  // RPE in the band below the ILM.
  for (std::int32_t a = 0; a < p.ascans; ++a) {
    w.origin[a] = w.ilm_px[a];
    for (std::int32_t s = 0; s < p.band; ++s) {
      w.cost[a * band + s] =
          detail::rpe_cost(column(a), p.depth, w.origin[a] + s, s, p.rpe_depth_cap, floor);
    }
  }
  solve_path(p.ascans, p.band, w.origin.data(), w.cost.data(), p.max_step, p.step_penalty,
             w.path.data(), w.forward, w.backward, w.next, w.steps);

  // Sub-px fits, and their contrasts against the B-scan's typical ones.
  std::array<std::uint32_t, detail::kHistogramBins> rpe_histogram{};
  std::array<std::uint32_t, detail::kHistogramBins> ilm_histogram{};
  std::array<std::uint32_t, detail::kHistogramBins> thickness_histogram{};
  const std::size_t row = bscan * ascans;
  std::vector<detail::ColumnFit>& fits = w.fits;
  fits.resize(ascans);
  for (std::int32_t a = 0; a < p.ascans; ++a) {
    const detail::ColumnFit fit =
        detail::fit_column(column(a), p.depth, w.ilm_px[a], w.path[a], floor, p.ilm_level);
    fits[a] = fit;
    ++rpe_histogram[detail::clamp_u8(fit.rpe_contrast)];
    ++ilm_histogram[detail::clamp_u8(fit.ilm_contrast)];
    ++thickness_histogram[detail::clamp_u8(w.path[a] - w.ilm_px[a])];
  }
  const int typical_rpe =
      detail::histogram_quantile(rpe_histogram.data(), static_cast<std::uint32_t>(ascans), 1, 2);
  const int typical_ilm =
      detail::histogram_quantile(ilm_histogram.data(), static_cast<std::uint32_t>(ascans), 1, 2);
  const int typical_thickness = detail::histogram_quantile(
      thickness_histogram.data(), static_cast<std::uint32_t>(ascans), 1, 2);
  const std::uint32_t fits_cycle = memory_.fits_cycle[bscan];
  const bool remember = detail::first_search_in_cycle(fits_cycle, memory_.clock.cycle);
  const detail::RememberSlots slots = memory_.remember_slots();
  int confident = 0;
  for (std::int32_t a = 0; a < p.ascans; ++a) {
    const detail::ColumnFit& fit = fits[a];
    const float confidence = detail::column_confidence(fit, typical_rpe, typical_ilm);
    confident += confidence >= 0.5f ? 1 : 0;
    const std::size_t i = row + a;
    if (remember) {
      detail::remember_fit(
          slots, static_cast<int>(i), fits_cycle, memory_.finished_kind[i],
          {memory_.ilm[i], memory_.rpe[i], memory_.bm[i]},
          {memory_.finished_ilm[i], memory_.finished_rpe[i], memory_.finished_bm[i]});
    }
    memory_.ilm[row + a] = fit.ilm;
    memory_.rpe[row + a] = fit.rpe;
    memory_.bm[row + a] = fit.bm;
    memory_.confidence[row + a] = confidence;
  }
  const bool retina =
      detail::retina_present(confident, p.ascans, p.presence_fraction, typical_rpe, typical_ilm,
                             p.min_contrast, typical_thickness, p.min_thickness);
  memory_.verdict[bscan] =
      static_cast<std::uint8_t>(retina ? BscanVerdict::retina : BscanVerdict::no_retina);
  memory_.fits_cycle[bscan] = memory_.clock.cycle;
}

}  // namespace ioct::gpu::segmentation
