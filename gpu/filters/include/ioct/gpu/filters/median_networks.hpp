// Branch-free selection of the median of 27 values (a 3x3x3 neighbourhood), written once for the
// CPU and for CUDA kernels. Every step is a compare-exchange (one min and one max), so it runs in
// registers with no data-dependent branch or index; T is a scalar (uint8_t ...) or a packed type
// holding several voxels, for which lane_min/lane_max are overloaded (found by ADL).
//
// Two algorithms, both exact:
//
// 1. Forgetful selection (the first paper, after Perrot et al.): the median of n values is
//    neither the minimum nor the maximum of any n/2 + 1 of them. Start with 15 of the 27 values,
//    move their min and max to the ends and forget them; add one more value, again forget min and
//    max; after 12 more values one remains: the median. 15 values are live at once, not 27.
//
// 2. Forgetful selection on sorted runs (what the CUDA kernel uses, because neighbouring outputs
//    share the work): the 27 values are three planes of 9 (B-scans z-1, z, z+1). Each plane is
//    sorted once (25 comparators) and serves three outputs. Two sorted planes are merged; of the
//    18, the 4 smallest and 4 largest each have at least 14 values on the other side, so they
//    cannot be the median of any 27 that include them and are forgotten at once: 10 survive, and
//    the same 10 serve the outputs at z and z+1. The median is then the 10th smallest of those 10
//    and the third plane's sorted 9, which is min over i of max(a_i, b_(10-i)). About 92 min/max
//    per output against about 300 for (1).
#pragma once

#include "ioct/gpu/cuda/host_device_function.hpp"

namespace ioct::gpu::filters {

template <class T>
IOCT_HD T lane_min(T a, T b) {
  return b < a ? b : a;
}
template <class T>
IOCT_HD T lane_max(T a, T b) {
  return b < a ? a : b;
}

// Afterwards a <= b.
template <class T>
IOCT_HD void compare_exchange(T& a, T& b) {
  const T low = lane_min(a, b);
  b = lane_max(a, b);
  a = low;
}

// Moves the minimum of v[Lo..Hi] to v[Lo] and the maximum to v[Hi]; the others stay in between.
// Pairs from both ends first, so the minimum is among the lower half and the maximum among the
// upper: about 1.5 (Hi - Lo + 1) compare-exchanges. The bounds are template arguments so that
// every index is a constant and the values stay in registers.
template <int Lo, int Hi, class T>
IOCT_HD void move_min_max_to_ends(T* v) {
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int p = 0; p < (Hi - Lo + 1) / 2; ++p) compare_exchange(v[Lo + p], v[Hi - p]);
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int k = Lo + 1; k <= (Lo + Hi) / 2; ++k) compare_exchange(v[Lo], v[k]);
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int k = (Lo + Hi + 1) / 2; k < Hi; ++k) compare_exchange(v[k], v[Hi]);
}

// Rounds Round..12 of algorithm (1): the next value goes into slot 14, where the maximum just
// forgotten was, and the new minimum is forgotten by starting the next round one slot higher.
template <int Round, class T>
IOCT_HD void forget_rounds(T (&v)[27]) {
  if constexpr (Round <= 12) {
    v[14] = v[14 + Round];
    move_min_max_to_ends<Round, 14>(v);
    forget_rounds<Round + 1>(v);
  }
}

// Algorithm (1). `v` is used as scratch.
template <class T>
IOCT_HD T median27_forgetful(T (&v)[27]) {
  move_min_max_to_ends<0, 14>(v);  // the first 15 values
  forget_rounds<1>(v);
  return v[13];
}

// Sorts 9 values ascending: Floyd's network of 25 comparators (depth 7).
template <class T>
IOCT_HD void sort9(T (&v)[9]) {
  compare_exchange(v[0], v[3]);
  compare_exchange(v[1], v[7]);
  compare_exchange(v[2], v[5]);
  compare_exchange(v[4], v[8]);
  compare_exchange(v[0], v[7]);
  compare_exchange(v[2], v[4]);
  compare_exchange(v[3], v[8]);
  compare_exchange(v[5], v[6]);
  compare_exchange(v[0], v[2]);
  compare_exchange(v[1], v[3]);
  compare_exchange(v[4], v[5]);
  compare_exchange(v[7], v[8]);
  compare_exchange(v[1], v[4]);
  compare_exchange(v[3], v[6]);
  compare_exchange(v[5], v[7]);
  compare_exchange(v[0], v[1]);
  compare_exchange(v[2], v[4]);
  compare_exchange(v[3], v[5]);
  compare_exchange(v[6], v[8]);
  compare_exchange(v[2], v[3]);
  compare_exchange(v[4], v[5]);
  compare_exchange(v[6], v[7]);
  compare_exchange(v[1], v[2]);
  compare_exchange(v[3], v[4]);
  compare_exchange(v[5], v[6]);
}

// The 10 middle values (ranks 5..14 of 18, ascending) of two ascending runs of 9: Batcher's
// odd-even merge of x (wires 0..8) and y (wires 9..17). Comparators that only feed the 4 smallest
// or 4 largest ranks are left to the compiler to drop.
template <class T>
IOCT_HD void merge9_middle10(const T (&x)[9], const T (&y)[9], T (&middle)[10]) {
  T w[18] = {x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8],
             y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7], y[8]};
  compare_exchange(w[0], w[9]);
  compare_exchange(w[8], w[17]);
  compare_exchange(w[8], w[9]);
  compare_exchange(w[4], w[13]);
  compare_exchange(w[4], w[8]);
  compare_exchange(w[13], w[9]);
  compare_exchange(w[2], w[11]);
  compare_exchange(w[6], w[15]);
  compare_exchange(w[6], w[11]);
  compare_exchange(w[2], w[4]);
  compare_exchange(w[6], w[8]);
  compare_exchange(w[11], w[13]);
  compare_exchange(w[15], w[9]);
  compare_exchange(w[1], w[10]);
  compare_exchange(w[5], w[14]);
  compare_exchange(w[5], w[10]);
  compare_exchange(w[3], w[12]);
  compare_exchange(w[7], w[16]);
  compare_exchange(w[7], w[12]);
  compare_exchange(w[3], w[5]);
  compare_exchange(w[7], w[10]);
  compare_exchange(w[12], w[14]);
  compare_exchange(w[1], w[2]);
  compare_exchange(w[3], w[4]);
  compare_exchange(w[5], w[6]);
  compare_exchange(w[7], w[8]);
  compare_exchange(w[10], w[11]);
  compare_exchange(w[12], w[13]);
  compare_exchange(w[14], w[15]);
  compare_exchange(w[16], w[9]);
  // Ranks 0..17 now sit on wires 0..8, 10..16, 9, 17.
  middle[0] = w[4];
  middle[1] = w[5];
  middle[2] = w[6];
  middle[3] = w[7];
  middle[4] = w[8];
  middle[5] = w[10];
  middle[6] = w[11];
  middle[7] = w[12];
  middle[8] = w[13];
  middle[9] = w[14];
}

// The 10th smallest of the ascending runs a (10 values) and b (9): the smallest k values are
// some i of a and 10 - i of b, and over all splits the largest of those is smallest for the true
// one. With merge9_middle10 of two planes as a and the third plane as b, this is the median of
// the 27.
template <class T>
IOCT_HD T select_median(const T (&a)[10], const T (&b)[9]) {
  T result = a[9];  // i = 10: all ten from a
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int i = 1; i <= 9; ++i) result = lane_min(result, lane_max(a[i - 1], b[9 - i]));
  return result;
}

// Algorithm (2) for one output from three unsorted planes (for tests and the CPU; the kernel
// keeps sorted planes and merges between outputs).
template <class T>
IOCT_HD T median27_sorted_runs(T (&below)[9], T (&centre)[9], T (&above)[9]) {
  sort9(below);
  sort9(centre);
  sort9(above);
  T middle[10];
  merge9_middle10(below, centre, middle);
  return select_median(middle, above);
}

}  // namespace ioct::gpu::filters
