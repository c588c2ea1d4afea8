// The arithmetic of one A-scan and of one step of the surface search, written once for the CPU
// reference and the CUDA kernels (host_device.hpp). Evidence and search costs are integers, so
// the two implementations choose the very same px; the sub-px refinements are the same float
// expressions in the same order (no fused multiply-add on either side).
//
// Columns are u8 A-scans of `depth` px, depth increasing downwards; reads outside [0, depth)
// repeat the edge px. `floor` is the B-scan's background level (u8).
#pragma once

#include <cstdint>

#include "ioct/gpu/cuda/host_device_function.hpp"
#include "ioct/gpu/segmentation/segmentation_config.hpp"

namespace ioct::gpu::segmentation::detail {

// Larger than any path total (4096 A-scans x kOutsideCost); marks a state no path reaches.
inline constexpr std::int32_t kUnreachable = 1 << 30;
// Cost of a state outside the depth axis: any path inside it is preferred.
inline constexpr std::int32_t kOutsideCost = 1 << 14;

// RPE evidence: bright here, against the brightest px 4..6 px above and 5..16 px below (half of
// each counts against). The RPE is a bright line between the dim outer segments and the choroid:
// the IS/OS line about 10 px above it has the RPE beneath it, a bright patch of choroid has the
// RPE above it.
inline constexpr int kRpeAboveFirst = 4;
inline constexpr int kRpeAboveLast = 6;
inline constexpr int kRpeBelowFirst = 5;
inline constexpr int kRpeBelowLast = 16;
// ILM evidence: a rise into tissue between d - 1 and d (levels above the background), minus the
// brightest px 4..14 px above (the vitreous must be dark; a deeper edge has retina above it). Half
// the mean level 3..14 px below counts for it, up to kIlmBelowCap: the retina is thick, a membrane
// detached from it (the posterior hyaloid, a lifted epiretinal membrane) is a thin line with the
// dark gap beneath.
inline constexpr int kIlmBelowFirst = 3;
inline constexpr int kIlmBelowLast = 14;
inline constexpr int kIlmBelowCap = 60;
inline constexpr int kIlmAboveFirst = 4;
inline constexpr int kIlmAboveLast = 14;
// The tissue beneath the RPE (choroid) whose mean enters the confidence.
inline constexpr int kChoroidFirst = 6;
inline constexpr int kChoroidLast = 25;
// Sub-px searches: the ILM reflex's peak lies within this many px below the steepest rise, the
// vitreous level is the darkest px within this many px above it.
inline constexpr int kIlmPeakReach = 6;
inline constexpr int kIlmBaseReach = 8;
inline constexpr int kRpePeakReach = 2;
inline constexpr int kBmReach = 10;

IOCT_HD int clamp_int(int v, int lo, int hi) {
  return v < lo ? lo : (v > hi ? hi : v);
}
IOCT_HD int max_int(int a, int b) {
  return a > b ? a : b;
}
IOCT_HD int min_int(int a, int b) {
  return a < b ? a : b;
}
IOCT_HD int abs_int(int a) {
  return a < 0 ? -a : a;
}

// Px `d` of a column, the edge px repeated outside it.
IOCT_HD int px(const std::uint8_t* column, int depth, int d) {
  return column[clamp_int(d, 0, depth - 1)];
}
// Level above the background.
IOCT_HD int above_floor(int value, int floor) {
  return value > floor ? value - floor : 0;
}

// The RPE evidence from the level at d and the brightest levels of its two windows (above the
// background): px by px (rpe_score) or from a column's levels kept in shared memory (the GPU's
// cost kernel), the same integers.
IOCT_HD int rpe_score_of_levels(int level, int brightest_above, int brightest_below) {
  return 2 * level - brightest_above / 2 - brightest_below / 2;
}

IOCT_HD int rpe_score(const std::uint8_t* column, int depth, int d, int floor) {
  int above = 0;
  for (int k = kRpeAboveFirst; k <= kRpeAboveLast; ++k) {
    above = max_int(above, above_floor(px(column, depth, d - k), floor));
  }
  int below = 0;
  for (int k = kRpeBelowFirst; k <= kRpeBelowLast; ++k) {
    below = max_int(below, above_floor(px(column, depth, d + k), floor));
  }
  return rpe_score_of_levels(above_floor(px(column, depth, d), floor), above, below);
}

// The ILM evidence from its three sums of levels (above the background) around depth d: the rise
// (d..d+2 less d-3..d-1), the vitreous above (d-kIlmAboveLast..d-kIlmAboveFirst) and the retina
// below (d+kIlmBelowFirst..d+kIlmBelowLast). Summed px by px (ilm_score) or from prefix sums (the
// GPU's cost kernel), the same integers.
inline constexpr int kIlmRiseAbove = 3;  // px above d in the rise
inline constexpr int kIlmRiseBelow = 2;  // px below d in it
IOCT_HD int ilm_score_of_sums(int rise, int above, int below) {
  return rise / 3 - above / (kIlmAboveLast - kIlmAboveFirst + 1) +
         min_int(below / (kIlmBelowLast - kIlmBelowFirst + 1), kIlmBelowCap) / 2;
}

IOCT_HD int ilm_score(const std::uint8_t* column, int depth, int d, int floor) {
  // Levels above the background: a dark border (no data) above the vitreous is no edge.
  const auto level = [&](int x) { return above_floor(px(column, depth, x), floor); };
  const int rise =
      level(d) + level(d + 1) + level(d + 2) - level(d - 1) - level(d - 2) - level(d - 3);
  int above = 0;
  for (int k = kIlmAboveFirst; k <= kIlmAboveLast; ++k) above += level(d - k);
  int below = 0;
  for (int k = kIlmBelowFirst; k <= kIlmBelowLast; ++k) below += level(d + k);
  return ilm_score_of_sums(rise, above, below);
}

// The coarse search works on cells of kCoarseCellPx px (a cell's level is its brightest px; the
// coarse evidence is a difference of levels, so it needs no background level and runs while the
// background is being measured) and on pairs of neighbouring A-scans (a pair's cost is its better
// column's).
// A cell's evidence: bright, against the cell above and the brightest of cells 2..4 below (half
// of each counts against: the same windows as the px evidence below), plus the mean level of the
// 6 cells above, capped at kAboveCap: the RPE has retina above it, the ILM's reflex the vitreous.
inline constexpr int kAboveCells = 6;
inline constexpr int kAboveCap = 40;

IOCT_HD int cell_level(const std::uint8_t* column, int depth, int cell) {
  int level = 0;
  for (int k = 0; k < kCoarseCellPx; ++k) {
    level = max_int(level, px(column, depth, cell * kCoarseCellPx + k));
  }
  return level;
}

// `levels` holds the cell levels of one column (`cells` of them); reads outside repeat the edge.
IOCT_HD int coarse_score(const std::uint8_t* levels, int cells, int k) {
  const auto at = [&](int i) { return static_cast<int>(levels[clamp_int(i, 0, cells - 1)]); };
  const int below = max_int(at(k + 2), max_int(at(k + 3), at(k + 4)));
  int above = 0;
  for (int i = 1; i <= kAboveCells; ++i) above += at(k - i);
  return 2 * at(k) - at(k - 1) / 2 - below / 2 + min_int(above / kAboveCells, kAboveCap);
}

// Fine RPE, `below_ilm` px below the ILM: the RPE evidence plus kDepthPriorWeight per px below
// the ILM up to `depth_cap` px. A thickness prior: the inner retina's reflex has the dark vitreous
// above it and can be as bright as the RPE, but the RPE lies deeper; where the retina is missing
// (a macular hole) the RPE's evidence still wins against the dimmer choroid beneath it.
inline constexpr int kDepthPriorWeight = 2;
IOCT_HD std::int32_t rpe_cost_of_score(int score, int below_ilm, int depth_cap) {
  return -(score + kDepthPriorWeight * min_int(below_ilm, depth_cap));
}
IOCT_HD std::int32_t rpe_cost(const std::uint8_t* column, int depth, int d, int below_ilm,
                              int depth_cap, int floor) {
  if (d < 0 || d >= depth) return kOutsideCost;
  return rpe_cost_of_score(rpe_score(column, depth, d, floor), below_ilm, depth_cap);
}
IOCT_HD std::int32_t ilm_cost_of_score(int score) {
  return -clamp_int(score, -255, 255);
}
IOCT_HD std::int32_t ilm_cost(const std::uint8_t* column, int depth, int d, int floor) {
  if (d < 0 || d >= depth) return kOutsideCost;
  return ilm_cost_of_score(ilm_score(column, depth, d, floor));
}
// The median of three coarse cells: the prior a B-scan takes from itself and its neighbours.
IOCT_HD std::int32_t median3(std::int32_t a, std::int32_t b, std::int32_t c) {
  const std::int32_t low = a < b ? a : b;
  const std::int32_t high = a < b ? b : a;
  return c < low ? low : (c > high ? high : c);
}

// Depth of state 0 of the ILM band above a coarse RPE cell: the band ends 4 px below the cell's
// centre (in a macular hole the first tissue is the RPE itself).
IOCT_HD std::int32_t ilm_band_origin(std::int32_t coarse_cell, std::int32_t band) {
  return coarse_cell * kCoarseCellPx + kCoarseCellPx / 2 + 4 - band;
}

// The i-th offset from a place, nearest first and the shallower first of two: 0, -1, +1, -2, +2,
// ... (the order the search tries its steps in, and the RPE's peak its neighbours).
IOCT_HD int nearest_first(int i) {
  return (i & 1) != 0 ? -((i + 1) >> 1) : (i >> 1);
}

// One state of one step of the search along a B-scan. `previous` holds the neighbouring A-scan's
// path totals over `states` states; this A-scan's band starts `shift` px deeper than the
// neighbour's. Returns the best total reaching state `s` from it (kUnreachable if none) and the
// step taken (this depth minus the neighbour's), trying steps in nearest_first's order so that
// ties go the same way everywhere.
IOCT_HD std::int32_t best_step(const std::int32_t* previous, int states, int s, int shift,
                               int max_step, int penalty, int* step) {
  std::int32_t best = kUnreachable;
  int chosen = 0;
  for (int i = 0; i < 2 * max_step + 1; ++i) {
    const int j = nearest_first(i);
    const int from = s + shift - j;
    if (from < 0 || from >= states) continue;
    const std::int32_t total = previous[from];
    if (total >= kUnreachable) continue;
    const std::int32_t candidate = total + penalty * abs_int(j);
    if (candidate < best) {
      best = candidate;
      chosen = j;
    }
  }
  *step = chosen;
  return best;
}

// One step back along a found path: the neighbouring column's state the step into `state` came
// from, where that column's band starts `shift` px shallower than this one's. Held in the band:
// a path always is, but where no state reached the middle column (a band that jumps past every
// state) the trace back starts from state 0 of nothing, and must not read past the steps.
IOCT_HD int state_before(int state, int shift, int step, int states) {
  return clamp_int(state + shift - step, 0, states - 1);
}

// A path total plus a state's cost, staying at kUnreachable.
IOCT_HD std::int32_t add_cost(std::int32_t total, std::int32_t cost) {
  return total >= kUnreachable ? kUnreachable : total + cost;
}

// The same step over keys (the GPU's, for a bound fixed at compile time): a key is a path total
// times kStepKeyScale, and a candidate's key adds its step's penalty (times the scale) and its
// place in the order of tried steps. One minimum over the candidates' keys is then the least total
// and, among equals, the first tried: best_step's choice, found by a tree of add-min operations
// (one instruction each on Hopper) instead of a chain of comparisons.
//
// A row of keys has kStepKeyPad unreachable keys on each side, so a step reads its candidates
// without a test of each: see step_key_base.
inline constexpr std::int32_t kStepKeyScale = 32;  // > the candidates of kMaxKeyedStep
inline constexpr int kMaxKeyedStep = 8;
inline constexpr int kStepKeyPad = 2 * kMaxKeyedStep + 1;
inline constexpr std::int32_t kUnreachableKey = 0x7f000000;
// Every total a half of a search reaches (at most kMaxAscans / 2 + 1 columns) lies within
// +-kLargestHalfTotal, and its key (with any step's penalty) below kUnreachableKey and above
// INT32_MIN: a state's cost is at most kOutsideCost and at least -(2 x 255 + kDepthPriorWeight x
// kMaxDepth) (rpe_cost), a step's penalty at most 2 x kMaxStepPenalty (the coarse search's) per px.
inline constexpr std::int64_t kLargestHalfTotal =
    (static_cast<std::int64_t>(kMaxAscans) / 2 + 1) *
    (kOutsideCost + 2 * std::int64_t{kMaxStepPenalty} * kMaxKeyedStep);
static_assert(kStepKeyScale > 2 * kMaxKeyedStep + 1);
static_assert((static_cast<std::int64_t>(kMaxAscans) / 2 + 1) *
                  (2 * 255 + kDepthPriorWeight * static_cast<std::int64_t>(kMaxDepth)) <=
              kLargestHalfTotal);
static_assert((kLargestHalfTotal + 1) * kStepKeyScale < kUnreachableKey);
static_assert(std::int64_t{kUnreachableKey} + 2 * kMaxStepPenalty * kMaxKeyedStep * kStepKeyScale +
                  kStepKeyScale <=
              INT32_MAX);

IOCT_HD std::int32_t step_key_of(std::int32_t total) {
  return total >= kUnreachable ? kUnreachableKey : total * kStepKeyScale;
}
IOCT_HD std::int32_t total_of_step_key(std::int32_t key) {
  return key >= kUnreachableKey ? kUnreachable : key / kStepKeyScale;
}

// Where a step reads its candidates in a padded row of `states` keys: this A-scan's state plus the
// band's shift, clamped so that the reads stay within the padding; a state clamped there has no
// candidate inside the row, and the padding answers unreachable for all of them as the row would.
template <int kFixedStep>
IOCT_HD int step_key_base(int states, int s, int shift) {
  static_assert(kFixedStep > 0 && kFixedStep <= kMaxKeyedStep);
  return clamp_int(s + shift, -kFixedStep - 1, states + kFixedStep);
}

IOCT_HD std::int32_t add_min(std::int32_t a, std::int32_t b, std::int32_t c) {
#if defined(__CUDA_ARCH__)
  return __viaddmin_s32(a, b, c);  // min(a + b, c)
#else
  return min_int(a + b, c);
#endif
}

// What each candidate of a step adds to its neighbour's key, for a step bound of kFixedStep: its
// step's penalty (times the scale) plus its place in the order tried (nearest_first). The same for
// every step of a search, so a search works them out once.
template <int kFixedStep>
struct StepKeyOffsets {
  std::int32_t of[2 * kFixedStep + 1];
};
template <int kFixedStep>
IOCT_HD StepKeyOffsets<kFixedStep> step_key_offsets(std::int32_t penalty) {
  StepKeyOffsets<kFixedStep> offsets{};
  for (int i = 0; i < 2 * kFixedStep + 1; ++i) {
    offsets.of[i] = penalty * kStepKeyScale * abs_int(nearest_first(i)) + i;
  }
  return offsets;
}

// best_step over keys, for a step bound of kFixedStep: `row` points at state 0 of a padded row of
// keys, `base` is step_key_base's; returns the best total reaching the state as a key
// (kUnreachableKey if none) and the place of the step taken in the order tried (0, the step 0,
// if none): the step is nearest_first(*order). The GPU's search decodes it beside the step's
// chain and keeps the step, so that the trace back, a chain of dependent reads, need not.
template <int kFixedStep>
IOCT_HD std::int32_t best_step_key(const std::int32_t* row, int base,
                                   const StepKeyOffsets<kFixedStep>& offsets, int* order) {
  constexpr int kCandidates = 2 * kFixedStep + 1;
  constexpr int kChains = 4;  // independent minima, joined at the end
  std::int32_t keys[kCandidates];
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int i = 0; i < kCandidates; ++i) keys[i] = row[base - nearest_first(i)];
  std::int32_t best[kChains] = {kUnreachableKey, kUnreachableKey, kUnreachableKey, kUnreachableKey};
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int i = 0; i < kCandidates; ++i) {
    best[i % kChains] = add_min(keys[i], offsets.of[i], best[i % kChains]);
  }
  const std::int32_t key = min_int(min_int(best[0], best[1]), min_int(best[2], best[3]));
  // The minima start at kUnreachableKey, whose place bits are 0, so a state no candidate reaches
  // comes out as kUnreachableKey and the step 0 (best_step's answer) without a test.
  static_assert((kUnreachableKey & (kStepKeyScale - 1)) == 0);
  *order = key & (kStepKeyScale - 1);
  // The candidate's total, its step's penalty included, as a key (the key less its place).
  return key & ~(kStepKeyScale - 1);
}

// A key plus a state's cost, staying unreachable.
IOCT_HD std::int32_t add_cost_key(std::int32_t key, std::int32_t cost) {
  return key >= kUnreachableKey ? kUnreachableKey : key + cost * kStepKeyScale;
}

// What the refinement of one A-scan found (px; NaN-free: the caller knows whether it applies).
struct ColumnFit {
  float ilm = 0.0f;
  float rpe = 0.0f;
  float bm = 0.0f;
  int rpe_contrast = 0;  // RPE peak above the background, u8 levels
  int ilm_contrast = 0;  // inner reflex peak above the vitreous level
  int choroid = 0;       // mean level of the tissue beneath the RPE above the background
};

// The RPE centre: the brightest px within kRpePeakReach of `d` (the first of equals, nearest
// first), and a parabola through it and its neighbours.
IOCT_HD int rpe_peak_px(const std::uint8_t* column, int depth, int d) {
  int best = clamp_int(d, 0, depth - 1);
  int value = column[best];
  for (int i = 1; i <= 2 * kRpePeakReach; ++i) {
    const int x = d + nearest_first(i);
    if (x < 0 || x >= depth) continue;
    if (column[x] > value) {
      value = column[x];
      best = x;
    }
  }
  return best;
}

IOCT_HD float parabola_offset(int left, int centre, int right) {
  const int curvature = left - 2 * centre + right;
  if (curvature >= 0) return 0.0f;
  float offset = 0.5f * static_cast<float>(left - right) / static_cast<float>(curvature);
  offset = offset < -0.5f ? -0.5f : offset;
  return offset > 0.5f ? 0.5f : offset;
}

// The ILM reflex's peak below the rise at `ilm_px`: the first local maximum within kIlmPeakReach
// px (a plateau counts). Returns its px; its value in `top`.
IOCT_HD int reflex_peak(const std::uint8_t* column, int depth, int ilm_px, int* top) {
  int p = ilm_px;
  int peak = px(column, depth, ilm_px);
  for (int k = 1; k <= kIlmPeakReach; ++k) {
    const int v = px(column, depth, ilm_px + k);
    if (v < peak) break;
    if (v > peak) {
      peak = v;
      p = ilm_px + k;
    }
  }
  *top = peak;
  return p;
}

// The vitreous level above the rise at `ilm_px`: the darkest of `start` and the kIlmBaseReach px
// above it.
IOCT_HD int darkest_above(const std::uint8_t* column, int depth, int ilm_px, int start) {
  int base = start;
  for (int k = 1; k <= kIlmBaseReach; ++k) base = min_int(base, px(column, depth, ilm_px - k));
  return base;
}

// The brightest px in [from, from + reach] (the first of equals; 0 and `from` for a black run).
// Returns its value; its px in `at`.
IOCT_HD int brightest(const std::uint8_t* column, int depth, int from, int reach, int* at) {
  int best = 0;
  *at = from;
  for (int k = 0; k <= reach; ++k) {
    const int v = px(column, depth, from + k);
    if (v > best) {
      best = v;
      *at = from + k;
    }
  }
  return best;
}

// The first px in (after, after + reach], and inside the column, at or below `level`; -1 if none.
IOCT_HD int first_at_or_below(const std::uint8_t* column, int depth, int after, int reach,
                              float level) {
  for (int x = after + 1; x <= after + reach && x < depth; ++x) {
    if (static_cast<float>(px(column, depth, x)) <= level) return x;
  }
  return -1;
}

// The px in (after, to] where the intensity rises most steeply (the deepest of equals).
IOCT_HD int steepest_rise(const std::uint8_t* column, int depth, int after, int to) {
  int steepest = to;
  int slope = -256;
  for (int y = to; y > after; --y) {
    const int rise = px(column, depth, y + 1) - px(column, depth, y - 1);
    if (rise > slope) {
      slope = rise;
      steepest = y;
    }
  }
  return steepest;
}

// A membrane lifted off the retina (an epiretinal membrane's wrinkle, the posterior hyaloid):
// the search may follow its reflex, the first rise into tissue. A membrane is thin: within
// kGapStartReach px below the reflex's peak lies a gap as dark as the vitreous (within kGapShare
// of the way from the vitreous level up to the reflex's peak), and within kGapReach px below the
// gap's start the retina, at least kTissueShare as bright as the reflex. Returns the px of the
// steepest rise out of the gap into the retina, or `ilm_px` where there is no such gap. The
// retina's dark layers are thicker than a membrane's gap: the fovea's ONL (as dark as a gap) has
// the ILM's reflex above it and the ELM and IS/OS lines more than kGapReach px below it.
inline constexpr int kGapStartReach = 8;
inline constexpr int kGapReach = 16;
inline constexpr float kGapShare = 0.15f;
inline constexpr int kTissueRun = 6;
inline constexpr float kTissueShare = 0.7f;
IOCT_HD int rise_beneath_membrane(const std::uint8_t* column, int depth, int ilm_px) {
  int top = 0;
  const int p = reflex_peak(column, depth, ilm_px, &top);  // as fit_column finds it
  const int base = darkest_above(column, depth, ilm_px, top);
  const float span = static_cast<float>(top - base);
  const float gap_level = static_cast<float>(base) + kGapShare * span;
  const float tissue_level = static_cast<float>(base) + kTissueShare * span;
  const int gap = first_at_or_below(column, depth, p, kGapStartReach, gap_level);
  if (gap < 0) return ilm_px;
  // The retina: the first px past the gap at the tissue level; the steepest rise before it.
  for (int x = gap + 1; x <= gap + kGapReach && x < depth; ++x) {
    if (static_cast<float>(px(column, depth, x)) < tissue_level) continue;
    int run = 0;
    for (int k = 0; k < kTissueRun; ++k) run += px(column, depth, x + k);
    if (static_cast<float>(run) < static_cast<float>(kTissueRun) * tissue_level) return ilm_px;
    return steepest_rise(column, depth, gap, x);
  }
  return ilm_px;
}

// A dim band on the retina (tissue on the optic disc's surface): the search may take its outer
// edge, the first rise into tissue. Its level is the brightest px within
// kBandLook px below the rise; the retina beneath it is at least kBandContrast times as far above
// the vitreous level, and the band stays at least kBandFloorShare of its level all the way down
// to it (the retina's own inner layers dip between the NFL and the deeper bright layers).
// Returns the px of the steepest rise into the retina within kBandReach px below the band's
// rise, or `ilm_px` where there is no such band. In the simulated retina the ILM's reflex is never
// half as bright as a layer beneath it.
inline constexpr int kBandLook = 8;
inline constexpr int kBandReach = 48;
inline constexpr float kBandContrast = 2.0f;
inline constexpr float kBandFloorShare = 0.85f;
IOCT_HD int rise_beneath_band(const std::uint8_t* column, int depth, int ilm_px) {
  const int base = darkest_above(column, depth, ilm_px, px(column, depth, ilm_px));
  int band_end = ilm_px;
  const int band = brightest(column, depth, ilm_px, kBandLook, &band_end);
  const int band_level = band - base;
  if (band_level <= 0) return ilm_px;
  const float lowest = static_cast<float>(base) + kBandFloorShare * static_cast<float>(band_level);
  const float bright = static_cast<float>(base) + kBandContrast * static_cast<float>(band_level);
  for (int x = band_end + 1; x <= ilm_px + kBandReach && x < depth; ++x) {
    const int v = px(column, depth, x);
    if (static_cast<float>(v) < lowest) return ilm_px;
    if (static_cast<float>(v) < bright) continue;
    return steepest_rise(column, depth, band_end, x);
  }
  return ilm_px;
}

// Refines the search's px (ILM at the steepest rise, RPE near its centre) of one A-scan.
IOCT_HD ColumnFit fit_column(const std::uint8_t* column, int depth, int ilm_px, int rpe_px,
                             int floor, float ilm_level) {
  ColumnFit fit;
  // RPE centre.
  const int r = rpe_peak_px(column, depth, rpe_px);
  const int peak = column[r];
  fit.rpe = static_cast<float>(r) +
            parabola_offset(px(column, depth, r - 1), peak, px(column, depth, r + 1));
  fit.rpe_contrast = above_floor(peak, floor);

  // Outer boundary: half-way from the peak down to the darkest px within kBmReach below it.
  int low = peak;
  for (int k = 1; k <= kBmReach; ++k) low = min_int(low, px(column, depth, r + k));
  const float bm_level = 0.5f * static_cast<float>(peak + low);
  fit.bm = static_cast<float>(r);
  for (int k = 0; k < kBmReach; ++k) {
    const int upper = px(column, depth, r + k);
    const int lower = px(column, depth, r + k + 1);
    if (static_cast<float>(lower) <= bm_level) {
      fit.bm = static_cast<float>(r + k) + (upper > lower ? (static_cast<float>(upper) - bm_level) /
                                                                static_cast<float>(upper - lower)
                                                          : 0.0f);
      break;
    }
  }

  // Tissue beneath the RPE.
  int sum = 0;
  for (int k = kChoroidFirst; k <= kChoroidLast; ++k) {
    sum += above_floor(px(column, depth, r + k), floor);
  }
  fit.choroid = sum / (kChoroidLast - kChoroidFirst + 1);

  // ILM: the retina's surface, beneath a lifted membrane or a dim band on it; the inner reflex's
  // peak below the steepest rise, the vitreous level above it, and where the rise crosses
  // ilm_level of the way between them.
  // (A third check, for a 12-47 px band lifted over a gap with brighter tissue beneath, took the
  // Spectralis disc's ILM 11.7 -> 9.9 px nearer but moved a normal retina's ILM into the retina
  // in the simulated appliance's scene, its mean error 0.65 -> 1.26 px: left out.)
  ilm_px = rise_beneath_membrane(column, depth, ilm_px);
  ilm_px = rise_beneath_band(column, depth, ilm_px);
  int top = 0;
  const int p = reflex_peak(column, depth, ilm_px, &top);
  const int base = darkest_above(column, depth, ilm_px, top);
  fit.ilm_contrast = top - base;
  const float level = static_cast<float>(base) + ilm_level * static_cast<float>(top - base);
  fit.ilm = static_cast<float>(p);
  for (int x = p - 1; x >= ilm_px - kIlmBaseReach; --x) {
    const int lower = px(column, depth, x);  // shallower px
    if (static_cast<float>(lower) < level) {
      const int upper = px(column, depth, x + 1);
      fit.ilm = static_cast<float>(x) +
                (level - static_cast<float>(lower)) / static_cast<float>(upper - lower);
      break;
    }
  }
  return fit;
}

// Confidence of one A-scan from its evidence against the B-scan's typical (median) contrasts:
// each of the RPE peak and the inner reflex counts fully at half its typical contrast, the tissue
// beneath the RPE (choroid) at kChoroidShare of the typical RPE contrast; the weakest one decides.
// An instrument's reflection has the dark vitreous above and its shadow beneath: no choroid.
inline constexpr float kChoroidShare = 0.05f;
IOCT_HD float column_confidence(const ColumnFit& fit, int typical_rpe, int typical_ilm) {
  const float rpe_ref = 0.5f * static_cast<float>(max_int(typical_rpe, 1));
  const float ilm_ref = 0.5f * static_cast<float>(max_int(typical_ilm, 1));
  const float choroid_ref = kChoroidShare * static_cast<float>(max_int(typical_rpe, 1));
  float c = static_cast<float>(fit.rpe_contrast) / rpe_ref;
  const float ilm = static_cast<float>(fit.ilm_contrast) / ilm_ref;
  const float choroid = static_cast<float>(fit.choroid) / choroid_ref;
  c = ilm < c ? ilm : c;
  c = choroid < c ? choroid : c;
  return c > 1.0f ? 1.0f : c;
}

// Whether a B-scan holds a retina: typical RPE and inner-reflex contrasts of at least
// min_contrast, a typical (median) ILM-to-RPE distance of at least min_thickness px (the cornea's
// epithelium and Bowman's layer look like an ILM over a thin RPE), and at least presence_fraction
// of its A-scans confident (>= 0.5).
IOCT_HD bool retina_present(int confident_ascans, int ascans, float presence_fraction,
                            int typical_rpe, int typical_ilm, int min_contrast,
                            int typical_thickness, int min_thickness) {
  return typical_rpe >= min_contrast && typical_ilm >= min_contrast &&
         typical_thickness >= min_thickness &&
         static_cast<float>(confident_ascans) >= presence_fraction * static_cast<float>(ascans);
}

}  // namespace ioct::gpu::segmentation::detail
