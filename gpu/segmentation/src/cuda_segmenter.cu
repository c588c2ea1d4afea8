#include <algorithm>
#include <array>
#include <cstddef>
#include <cstring>
#include <cub/warp/warp_reduce.cuh>
#include <cub/warp/warp_scan.cuh>
#include <cuda/functional>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/cuda/pinned_download.hpp"
#include "ioct/gpu/segmentation/column_math.hpp"
#include "ioct/gpu/segmentation/cuda_segmenter.hpp"
#include "ioct/gpu/segmentation/finishing.hpp"
#include "ioct/gpu/segmentation/histogram.hpp"
#include "ioct/gpu/segmentation/lifted_rpe.hpp"

namespace ioct::gpu::segmentation {

namespace {

using detail::kHistogramBins;
using detail::kUnreachable;

constexpr int kCostThreads = 256;
constexpr int kPairsPerCostBlock = 8;
constexpr int kColumnsPerCostBlock = 16;
constexpr int kFinishThreads = 128;
constexpr int kFitThreads = 64;        // a fit per thread: many small blocks
constexpr int kVerdictThreads = 256;   // a B-scan per block
constexpr int kMembraneThreads = 512;  // a B-scan per block
// membrane_kernel's rows: within the 48 KiB a launch may take without opting in.
static_assert(3 * kMaxAscans * sizeof(float) <= 48 * 1024);
// The searches' kernels are built for blocks of up to this many threads (registers for a whole
// chunk, 128 a thread) and of up to 1024 (the coarse search of a 2048 px axis: 512 cells a half).
constexpr int kSearchThreads = 512;
// Search columns whose costs a thread loads at once: 16, or 8 in the larger blocks (half the
// registers a thread).
template <int kMaxThreads>
constexpr int kChunk = kMaxThreads <= kSearchThreads ? 16 : 8;
// Shared memory a search may use for its step choices; more goes to global memory (slower trace
// back, same result).
constexpr std::size_t kSharedStepsLimit = 160 * 1024;

// Copies n bytes from global to shared memory with the whole block, 16 at a time where both
// sides allow it (the volume is cudaMalloc'd; columns of a multiple of 16 px stay aligned).
__device__ void stage_bytes(std::uint8_t* shared, const std::uint8_t* global, std::size_t n) {
  std::size_t done = 0;
  if (((reinterpret_cast<std::uintptr_t>(global) | reinterpret_cast<std::uintptr_t>(shared)) &
       15u) == 0) {
    const std::size_t vectors = n / 16;
    const uint4* from = reinterpret_cast<const uint4*>(global);
    uint4* to = reinterpret_cast<uint4*>(shared);
    for (std::size_t i = threadIdx.x; i < vectors; i += blockDim.x) to[i] = __ldg(from + i);
    done = vectors * 16;
  }
  for (std::size_t i = done + threadIdx.x; i < n; i += blockDim.x) shared[i] = __ldg(global + i);
}

// histogram_quantile by one warp: each lane sums 8 neighbouring bins, a warp scan gives every
// lane the count before its bins, and the first lane whose bins reach the quantile finds the bin
// among its 8. The same bin as the serial walk (whose 256 dependent steps cost a few us on one
// thread), in every lane of the warp.
__device__ int warp_histogram_quantile(const std::uint32_t* histogram, std::uint32_t count,
                                       std::uint32_t numerator, std::uint32_t denominator) {
  static_assert(kHistogramBins == 32 * 8);
  if (count == 0) return 0;
  const int lane = static_cast<int>(threadIdx.x % 32);
  const std::uint32_t* own = histogram + lane * 8;
  std::uint64_t own_sum = 0;
#pragma unroll
  for (int i = 0; i < 8; ++i) own_sum += own[i];
  using WarpScan = cub::WarpScan<std::uint64_t>;
  __shared__ typename WarpScan::TempStorage storage[1024 / 32];  // a warp's own, up to 1024 threads
  std::uint64_t before = 0;
  WarpScan(storage[threadIdx.x / 32]).ExclusiveSum(own_sum, before);
  const std::uint64_t target = std::uint64_t{count} * numerator;
  const bool reaches = (before + own_sum) * denominator >= target;
  const unsigned lanes = __ballot_sync(0xffffffffu, reaches);
  if (lanes == 0) return kHistogramBins - 1;
  const int first = __ffs(lanes) - 1;
  int bin = kHistogramBins - 1;
  if (lane == first) {
    std::uint64_t cumulative = before;
    for (int i = 0; i < 8; ++i) {
      cumulative += own[i];
      if (cumulative * denominator >= target) {
        bin = lane * 8 + i;
        break;
      }
    }
  }
  return __shfl_sync(0xffffffffu, bin, first);
}

// ---------------------------------------------------------------------------------------------
// Coarse costs: per pair of A-scans and cell, the better column's negated cell evidence; and the
// histogram of the background samples (histogram.hpp) of the block's columns, for the B-scan's
// background level, which the coarse search sums.

struct CoarseCostJob {
  const std::uint8_t* volume;
  std::uint32_t* histograms;  // [group][cost block][bins]
  std::int32_t* cost;         // [group][coarse column][cell]
  detail::CycleClock* clock;  // advanced by the first block, read by the fits
  int first;
  SegmentationParams p;
};

__global__ void coarse_cost_kernel(CoarseCostJob job) {
  // [kPairsPerCostBlock * kCoarsePair][depth] px, then [same columns][cells] levels.
  extern __shared__ __align__(16) std::uint8_t staged[];
  __shared__ std::uint32_t bins[kHistogramBins];
  const SegmentationParams& p = job.p;
  const int g = blockIdx.y;
  const int b = job.first + g;
  const std::size_t bscan_px = static_cast<std::size_t>(p.ascans) * p.depth;
  const int first_pair = blockIdx.x * kPairsPerCostBlock;
  const int first_column = first_pair * kCoarsePair;
  const int columns = min(kPairsPerCostBlock * kCoarsePair, p.ascans - first_column);
  if (blockIdx.x == 0 && blockIdx.y == 0 && threadIdx.x == 0) {
    detail::advance_cycle(*job.clock, job.first);
  }
  std::uint8_t* px = staged;
  std::uint8_t* levels =
      staged + static_cast<std::size_t>(kPairsPerCostBlock) * kCoarsePair * p.depth;
  for (int i = threadIdx.x; i < kHistogramBins; i += blockDim.x) bins[i] = 0;
  const std::size_t offset = static_cast<std::size_t>(first_column) * p.depth;
  const std::size_t n = static_cast<std::size_t>(columns) * p.depth;
  stage_bytes(px, job.volume + static_cast<std::size_t>(b) * bscan_px + offset, n);
  __syncthreads();
  // Background samples: the px whose index in the B-scan is a multiple of the stride.
  const std::size_t stride = detail::kFloorSampleStride;
  const std::size_t first_sample = (offset + stride - 1) / stride * stride - offset;
  const std::size_t samples = first_sample < n ? (n - first_sample + stride - 1) / stride : 0;
  for (std::size_t base = 0; base < samples; base += blockDim.x) {  // same trip count everywhere
    const std::size_t i = base + threadIdx.x;
    const unsigned value = i < samples ? px[first_sample + i * stride] : 256u;
    const unsigned same = __match_any_sync(0xffffffffu, value);
    if (value < 256u && (threadIdx.x & 31) == static_cast<unsigned>(__ffs(same) - 1)) {
      atomicAdd(&bins[value], static_cast<std::uint32_t>(__popc(same)));
    }
  }
  for (int i = threadIdx.x; i < columns * p.coarse_cells; i += blockDim.x) {
    const int c = i % p.coarse_cells;
    const int k = i / p.coarse_cells;
    levels[i] = static_cast<std::uint8_t>(
        detail::cell_level(px + static_cast<std::size_t>(k) * p.depth, p.depth, c));
  }
  __syncthreads();
  std::uint32_t* histogram =
      job.histograms + (static_cast<std::size_t>(g) * gridDim.x + blockIdx.x) * kHistogramBins;
  for (int i = threadIdx.x; i < kHistogramBins; i += blockDim.x) histogram[i] = bins[i];
  for (int i = threadIdx.x; i < kPairsPerCostBlock * p.coarse_cells; i += blockDim.x) {
    const int c = i % p.coarse_cells;
    const int pair = i / p.coarse_cells;
    const int q = first_pair + pair;
    if (q >= p.coarse_columns) continue;
    std::int32_t cost = detail::kOutsideCost;
    for (int k = 0; k < kCoarsePair; ++k) {
      const int a = q * kCoarsePair + k;
      if (a >= p.ascans) break;
      const std::int32_t c_cost = -detail::coarse_score(
          levels + (pair * kCoarsePair + k) * p.coarse_cells, p.coarse_cells, c);
      cost = min(cost, c_cost);
    }
    job.cost[(static_cast<std::size_t>(g) * p.coarse_columns + q) * p.coarse_cells + c] = cost;
  }
}

// ---------------------------------------------------------------------------------------------
// The search along a B-scan (see solve_path in cpu_segmenter.cpp): one block per B-scan, the
// first half of the threads walks from the left to the middle column, the second from the right.
// The coarse search also sums the background histogram and sets the B-scan's level; the RPE
// search goes on to the sub-px fits, the typical contrasts, the confidences and the verdict.

enum class PathStage { coarse, ilm, rpe };

struct PathJob {
  const std::int32_t* cost;    // [group][columns][states]
  const std::int32_t* origin;  // [group][columns], or null for all 0
  std::int32_t* path;          // [group][columns]: depth (or cell) per column
  std::int8_t* global_steps;   // [group][columns][states] when they do not fit in shared memory
  int first;
  int columns;
  int states;
  int max_step;
  int penalty;
  int half_threads;  // threads per half, a multiple of 32, >= states
  bool shared_steps;
  PathStage stage;
  SegmentationParams p;
  // Coarse stage.
  const std::uint32_t* histograms;  // [group][histogram blocks][bins]
  int histogram_blocks;
  std::int32_t* coarse;        // memory's [bscan][ascan] cells
  std::uint8_t* coarse_valid;  // [bscan]
  std::uint8_t* floors;        // [bscan]
};

__device__ __forceinline__ std::int32_t load_cost(const std::int32_t* cost, int columns, int states,
                                                  int column, int s) {
  if (column < 0 || column >= columns || s >= states) return 0;
  return __ldg(cost + static_cast<std::size_t>(column) * states + s);
}

// The B-scan's background level from the coarse cost blocks' histograms.
__device__ void sum_background(const PathJob& job, int g, int b) {
  __shared__ std::uint32_t bins[kHistogramBins];
  const std::uint32_t* partial =
      job.histograms + static_cast<std::size_t>(g) * job.histogram_blocks * kHistogramBins;
  for (int v = threadIdx.x; v < kHistogramBins; v += blockDim.x) {
    std::uint32_t sum = 0;
    for (int k = 0; k < job.histogram_blocks; ++k) sum += __ldg(partial + k * kHistogramBins + v);
    bins[v] = sum;
  }
  __syncthreads();
  if (threadIdx.x < 32) {
    const std::size_t bscan_px = static_cast<std::size_t>(job.p.ascans) * job.p.depth;
    const auto samples = static_cast<std::uint32_t>((bscan_px + detail::kFloorSampleStride - 1) /
                                                    detail::kFloorSampleStride);
    const int floor =
        warp_histogram_quantile(bins, samples, detail::kFloorNumerator, detail::kFloorDenominator);
    if (threadIdx.x == 0) job.floors[b] = static_cast<std::uint8_t>(floor);
  }
}

// kMaxThreads: the block's size bounds the registers a thread may hold, so a search of up to
// kSearchThreads gets the kernel built for them (the costs and band shifts of a chunk, the step's
// offsets in registers) and only a larger one the kernel built for 1024.
template <int kFixedStep, int kMaxThreads>
__global__ void __launch_bounds__(kMaxThreads) path_kernel(PathJob job) {
  extern __shared__ __align__(16) unsigned char shared[];
  const int g = blockIdx.x;
  const int b = job.first + g;
  const int S = job.states;
  const int N = job.columns;
  // With the step bound fixed, the rows hold keys with unreachable padding (column_math.hpp,
  // best_step_key); else plain totals. Either way the steps taken are kept as steps.
  constexpr bool kKeys = kFixedStep > 0;
  constexpr int kPad = kKeys ? detail::kStepKeyPad : 0;
  const int R = S + 2 * kPad;  // a row's length
  // Shared memory: rows [2 halves][2 buffers][R] int32, origins [N] int32, keys [32] u64, steps.
  std::int32_t* rows = reinterpret_cast<std::int32_t*>(shared);
  std::int32_t* origin = rows + 4 * R;
  unsigned long long* keys = reinterpret_cast<unsigned long long*>(origin + N + (N & 1));
  std::int8_t* const shared_steps = reinterpret_cast<std::int8_t*>(keys + 32);
  std::int8_t* const global_steps =
      job.shared_steps ? nullptr : job.global_steps + static_cast<std::size_t>(g) * N * S;
  const std::int32_t* cost = job.cost + static_cast<std::size_t>(g) * N * S;

  if (job.stage == PathStage::coarse) sum_background(job, g, b);
  for (int i = threadIdx.x; i < N; i += blockDim.x) {
    origin[i] = job.origin != nullptr ? job.origin[static_cast<std::size_t>(g) * N + i] : 0;
  }
  const int half = threadIdx.x / job.half_threads;  // 0: from the left, 1: from the right
  const int s = threadIdx.x % job.half_threads;
  const bool active = s < S;
  std::int32_t* buffer0 = rows + half * 2 * R + kPad;  // state 0 of this half's two rows
  std::int32_t* buffer1 = buffer0 + R;
  const int middle = N / 2;
  const int iterations = max(middle, N - 1 - middle);
  // This half walks from its end column towards the middle: at iteration i (1-based, up to its
  // own count) it works on column end + direction x i, and keeps the step into it at that column
  // (from the left) or the next one (from the right: the middle column's two steps do not share a
  // place), i.e. at the column plus the half.
  const int own_iterations = half == 0 ? middle : N - 1 - middle;
  const int end = half == 0 ? 0 : N - 1;
  const int direction = half == 0 ? 1 : -1;
  if constexpr (kKeys) {
    for (int i = threadIdx.x; i < 4 * 2 * kPad; i += blockDim.x) {
      const int pad = i % (2 * kPad);  // [0, kPad) before a row's states, the rest after them
      rows[(i / (2 * kPad)) * R + (pad < kPad ? pad : S + pad)] = detail::kUnreachableKey;
    }
  }
  const auto to_row = [](std::int32_t total) { return kKeys ? detail::step_key_of(total) : total; };
  if (active) buffer0[s] = to_row(load_cost(cost, N, S, end, s));
  // The candidates' offsets, the same for every step (unused without keys).
  constexpr int kOffsetsStep = kKeys ? kFixedStep : 1;
  const detail::StepKeyOffsets<kOffsetsStep> offsets =
      detail::step_key_offsets<kOffsetsStep>(job.penalty);
  const std::int32_t* own_costs = cost + s;  // column a's cost of this state: own_costs[a * S]
  __syncthreads();

  // Iteration i reads the row of iteration i - 1 and writes its own, the rows alternating by the
  // iteration's parity. A chunk starts at an odd iteration and holds an even number of them, so
  // within it the parity, and with it the two rows, is known at compile time: a step spends no
  // instructions on swapping them. A half that is done writes nothing more: its last row stays
  // in the row of its own last iteration's parity, where the join looks for it.
  constexpr int kColumns = kChunk<kMaxThreads>;
  static_assert(kColumns % 2 == 0);
  // Iteration i's column is end + direction x i: its cost of this state own_costs[column x S],
  // its step's place own_step_place + i x column_stride.
  const int column_stride = direction * S;
  const int own_step_place = (end + half) * S + s;  // iteration 0's
  // Where a step reads the row before, from the band's shift between the two columns and the
  // parity of the step: with keys the place in `rows` of step_key_base's state in that row
  // (worked out before the step's barrier, off its chain of dependent instructions), else the
  // shift itself.
  const int own_row = static_cast<int>(buffer0 - rows);  // state 0 of this half's row 0
  const auto read_of = [&](int shift, bool odd) {
    if constexpr (kKeys) {
      return own_row + (odd ? 0 : R) + detail::step_key_base<kFixedStep>(S, s, shift);
    } else {
      return shift;
    }
  };
  // One step of the search: iteration i, into the row of parity kOdd, reading the row before at
  // read_of's answer, with this column's cost. Every thread reaches its barrier.
  const auto search_step = [&](auto odd, int i, int read, std::int32_t cost) {
    std::int32_t* const next = decltype(odd)::value ? buffer1 : buffer0;
    if (active && i <= own_iterations) {
      int kept = 0;  // the step taken
      if constexpr (kKeys) {
        int order = 0;
        next[s] = detail::add_cost_key(
            detail::best_step_key<kFixedStep>(rows, read, offsets, &order), cost);
        // Kept as the step, not its place in the order tried: the decoding then sits beside
        // the step's chain, not in the trace back's, whose every link waits on it.
        kept = detail::nearest_first(order);
      } else {
        const std::int32_t* const previous = decltype(odd)::value ? buffer0 : buffer1;
        const std::int32_t best =
            detail::best_step(previous, S, s, read, job.max_step, job.penalty, &kept);
        next[s] = detail::add_cost(best, cost);
      }
      // Shared or global memory, chosen for the whole block: each store of its own kind.
      const int at = own_step_place + i * column_stride;
      if (job.shared_steps) {
        shared_steps[at] = static_cast<std::int8_t>(kept);
      } else {
        global_steps[at] = static_cast<std::int8_t>(kept);
      }
    }
    __syncthreads();
  };
  using Odd = std::integral_constant<bool, true>;
  using Even = std::integral_constant<bool, false>;
  // Whole chunks: the chunk's costs and band shifts loaded together (one wait for memory per
  // chunk, none between the barriers of its steps), the next chunk's costs while this one runs,
  // and no test of the iteration count per step.
  const int whole_chunks = iterations / kColumns;
  std::int32_t costs[kColumns];
  std::int32_t next_costs[kColumns];
  const auto load_costs = [&](int first, std::int32_t(&into)[kColumns]) {
    const int column_place = (end + direction * first) * S;
#pragma unroll
    for (int k = 0; k < kColumns; ++k) {
      into[k] = active && first + k <= own_iterations
                    ? __ldg(own_costs + (column_place + k * column_stride))
                    : 0;
    }
  };
  if (whole_chunks > 0) load_costs(1, costs);
  for (int chunk = 0; chunk < whole_chunks; ++chunk) {
    const int first = 1 + chunk * kColumns;
    if (chunk + 1 < whole_chunks) load_costs(first + kColumns, next_costs);
    // The chunk's columns and the one before it are all within the B-scan.
    int reads[kColumns];
    int before = origin[end + direction * (first - 1)];
#pragma unroll
    for (int k = 0; k < kColumns; ++k) {
      const int here = origin[end + direction * (first + k)];
      reads[k] = read_of(here - before, (k & 1) == 0);
      before = here;
    }
#pragma unroll
    for (int k = 0; k < kColumns; k += 2) {
      search_step(Odd{}, first + k, reads[k], costs[k]);
      search_step(Even{}, first + k + 1, reads[k + 1], costs[k + 1]);
    }
#pragma unroll
    for (int k = 0; k < kColumns; ++k) costs[k] = next_costs[k];
  }
  // The rest, a step at a time (odd iterations first, as in a chunk).
  for (int i = 1 + whole_chunks * kColumns; i <= iterations; i += 2) {
    const auto shift_cost = [&](int at, std::int32_t& cost) {
      const int a = end + direction * at;
      const bool working = at <= own_iterations;
      cost = active && working ? __ldg(own_costs + a * S) : 0;
      return working ? origin[a] - origin[a - direction] : 0;
    };
    std::int32_t cost = 0;
    int shift = shift_cost(i, cost);
    search_step(Odd{}, i, read_of(shift, true), cost);
    if (i + 1 <= iterations) {
      shift = shift_cost(i + 1, cost);
      search_step(Even{}, i + 1, read_of(shift, false), cost);
    }
  }
  __syncthreads();  // (no iteration at all for a single column)

  // Join at the middle column: the state of least forward + backward - its cost, the first of
  // equals (keys order by total, then state).
  const int forward_rows = middle;
  const int backward_rows = N - 1 - middle;
  const std::int32_t* forward = rows + ((forward_rows & 1) != 0 ? R : 0) + kPad;
  const std::int32_t* backward = rows + 2 * R + ((backward_rows & 1) != 0 ? R : 0) + kPad;
  const auto from_row = [](std::int32_t v) { return kKeys ? detail::total_of_step_key(v) : v; };
  unsigned long long key = ~0ull;
  const std::int32_t forward_total = active ? from_row(forward[s]) : kUnreachable;
  const std::int32_t backward_total = active ? from_row(backward[s]) : kUnreachable;
  if (half == 0 && forward_total < kUnreachable && backward_total < kUnreachable) {
    const std::int32_t total = forward_total + backward_total - load_cost(cost, N, S, middle, s);
    key = (static_cast<unsigned long long>(static_cast<std::uint32_t>(total) ^ 0x80000000u) << 32) |
          static_cast<unsigned long long>(s);
  }
  using WarpMin = cub::WarpReduce<unsigned long long>;
  __shared__ typename WarpMin::TempStorage warp_storage[1024 / 32];  // up to 1024 threads
  key = WarpMin(warp_storage[threadIdx.x / 32]).Reduce(key, ::cuda::minimum<>{});
  const int warp = threadIdx.x / 32;
  const int warps = blockDim.x / 32;
  if (threadIdx.x % 32 == 0) keys[warp] = key;
  __syncthreads();
  if (threadIdx.x == 0) {
    unsigned long long best = ~0ull;
    for (int w = 0; w < warps; ++w) best = keys[w] < best ? keys[w] : best;
    keys[0] = best;
  }
  __syncthreads();
  const int best_state = keys[0] == ~0ull ? 0 : static_cast<int>(keys[0] & 0xffffffffull);

  // Back along the steps taken: one thread to the left end, one (another warp) to the right. A
  // trace is a chain of dependent reads, so each runs on the steps' own kind of memory (shared
  // memory's loads, where they fit, are the shortest links).
  std::int32_t* path = job.path + static_cast<std::size_t>(g) * N;
  const auto trace = [&](const std::int8_t* steps) {
    const auto step_at = [&](int column, int state) { return steps[column * S + state]; };
    if (threadIdx.x == 0) {
      int state = best_state;
      path[middle] = origin[middle] + state;
      for (int a = middle; a >= 1; --a) {
        state = detail::state_before(state, origin[a] - origin[a - 1], step_at(a, state), S);
        path[a - 1] = origin[a - 1] + state;
      }
    } else if (threadIdx.x == job.half_threads) {
      int state = best_state;
      for (int a = middle; a <= N - 2; ++a) {
        state = detail::state_before(state, origin[a] - origin[a + 1], step_at(a + 1, state), S);
        path[a + 1] = origin[a + 1] + state;
      }
    }
  };
  if (job.shared_steps) {
    trace(shared_steps);
  } else {
    trace(global_steps);
  }
  if (job.stage != PathStage::coarse) return;
  __syncthreads();
  // The coarse cells of every A-scan, for this B-scan's and its neighbours' fine searches.
  for (int a = threadIdx.x; a < job.p.ascans; a += blockDim.x) {
    job.coarse[static_cast<std::size_t>(b) * job.p.ascans + a] = path[a / kCoarsePair];
  }
  if (threadIdx.x == 0) job.coarse_valid[b] = 1;
}

// ---------------------------------------------------------------------------------------------
// Fits, after the RPE search: each A-scan's sub-px surfaces and contrasts (a thread per A-scan:
// a fit walks its column serially, so it is spread over many blocks rather than left to the
// search's one block per B-scan), then each B-scan's typical contrasts, confidences and verdict.

struct FitJob {
  const std::uint8_t* volume;
  const std::uint8_t* floors;  // [bscan]
  const std::int32_t* ilm_px;  // [group][ascan]
  const std::int32_t* rpe_px;  // [group][ascan]
  float* ilm;                  // memory [bscan][ascan]
  float* rpe;
  float* bm;
  float* confidence;
  std::uint8_t* verdict;    // [bscan]
  std::uint8_t* contrasts;  // scratch [group][ascan][3]: rpe, ilm, choroid
  // Before the fits are replaced, the first search of a B-scan in a cycle remembers what its
  // last finishing found, measured or carried (finishing.hpp, remember_fit); the verdicts then
  // note the cycle of the new fits.
  const detail::CycleClock* clock;
  std::uint32_t* fits_cycle;  // [bscan]
  const detail::FinishedKind* finished_kind;
  const float* finished_ilm;  // the surfaces
  const float* finished_rpe;
  const float* finished_bm;
  detail::RememberSlots remembered;
  int first;
  SegmentationParams p;
};

__global__ void fit_kernel(FitJob job) {
  const int a = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  const SegmentationParams& p = job.p;
  if (a >= p.ascans) return;
  const int g = static_cast<int>(blockIdx.y);
  const int b = job.first + g;
  const std::size_t row = static_cast<std::size_t>(b) * p.ascans;
  const std::size_t group_row = static_cast<std::size_t>(g) * p.ascans;
  const std::uint8_t* column = job.volume + (row + a) * p.depth;
  const detail::ColumnFit fit =
      detail::fit_column(column, p.depth, job.ilm_px[group_row + a], job.rpe_px[group_row + a],
                         job.floors[b], p.ilm_level);
  const std::uint32_t fits_cycle = job.fits_cycle[b];
  if (detail::first_search_in_cycle(fits_cycle, job.clock->cycle)) {
    const int i = static_cast<int>(row) + a;
    detail::remember_fit(job.remembered, i, fits_cycle, job.finished_kind[i],
                         {job.ilm[i], job.rpe[i], job.bm[i]},
                         {job.finished_ilm[i], job.finished_rpe[i], job.finished_bm[i]});
  }
  job.ilm[row + a] = fit.ilm;
  job.rpe[row + a] = fit.rpe;
  job.bm[row + a] = fit.bm;
  std::uint8_t* c = job.contrasts + (group_row + a) * 3;
  c[0] = static_cast<std::uint8_t>(detail::clamp_u8(fit.rpe_contrast));
  c[1] = static_cast<std::uint8_t>(detail::clamp_u8(fit.ilm_contrast));
  c[2] = static_cast<std::uint8_t>(detail::clamp_u8(fit.choroid));
}

__global__ void verdict_kernel(FitJob job) {
  __shared__ std::uint32_t rpe_histogram[kHistogramBins];
  __shared__ std::uint32_t ilm_histogram[kHistogramBins];
  __shared__ std::uint32_t thickness_histogram[kHistogramBins];
  __shared__ int typical[3];
  __shared__ int confident;
  const SegmentationParams& p = job.p;
  const int g = static_cast<int>(blockIdx.x);
  const int b = job.first + g;
  for (int i = threadIdx.x; i < kHistogramBins; i += blockDim.x) {
    rpe_histogram[i] = 0;
    ilm_histogram[i] = 0;
    thickness_histogram[i] = 0;
  }
  if (threadIdx.x == 0) confident = 0;
  __syncthreads();
  const std::size_t row = static_cast<std::size_t>(b) * p.ascans;
  const std::size_t group_row = static_cast<std::size_t>(g) * p.ascans;
  for (int a = threadIdx.x; a < p.ascans; a += blockDim.x) {
    const std::uint8_t* c = job.contrasts + (group_row + a) * 3;
    atomicAdd(&rpe_histogram[c[0]], 1u);
    atomicAdd(&ilm_histogram[c[1]], 1u);
    atomicAdd(&thickness_histogram[detail::clamp_u8(job.rpe_px[group_row + a] -
                                                    job.ilm_px[group_row + a])],
              1u);
  }
  __syncthreads();
  const auto count = static_cast<std::uint32_t>(p.ascans);
  // Three medians, a warp each.
  static_assert(kVerdictThreads >= 3 * 32);
  const std::uint32_t* histograms[3] = {rpe_histogram, ilm_histogram, thickness_histogram};
  const int warp = static_cast<int>(threadIdx.x / 32);
  if (warp < 3) {
    const int median = warp_histogram_quantile(histograms[warp], count, 1, 2);
    if (threadIdx.x % 32 == 0) typical[warp] = median;
  }
  __syncthreads();
  int mine = 0;
  for (int a = threadIdx.x; a < p.ascans; a += blockDim.x) {
    const std::uint8_t* c = job.contrasts + (group_row + a) * 3;
    detail::ColumnFit fit;
    fit.rpe_contrast = c[0];
    fit.ilm_contrast = c[1];
    fit.choroid = c[2];
    const float confidence = detail::column_confidence(fit, typical[0], typical[1]);
    job.confidence[row + a] = confidence;
    mine += confidence >= 0.5f ? 1 : 0;
  }
  if (mine != 0) atomicAdd(&confident, mine);
  __syncthreads();
  if (threadIdx.x == 0) {
    const bool retina =
        detail::retina_present(confident, p.ascans, p.presence_fraction, typical[0], typical[1],
                               p.min_contrast, typical[2], p.min_thickness);
    job.verdict[b] =
        static_cast<std::uint8_t>(retina ? BscanVerdict::retina : BscanVerdict::no_retina);
    job.fits_cycle[b] = job.clock->cycle;
  }
}

// ---------------------------------------------------------------------------------------------
// Fine costs: the ILM band above the neighbours' coarse RPE (ilm_cost_kernel), the RPE band below
// the ILM (rpe_cost_kernel).

struct BandCostJob {
  const std::uint8_t* volume;
  const std::uint8_t* floors;        // [bscan]
  const std::int32_t* coarse;        // [bscan][ascan] (ILM band)
  const std::uint8_t* coarse_valid;  // [bscan]
  const std::int32_t* ilm_px;        // [group][ascan] (RPE band)
  std::int32_t* origin;              // [group][ascan]
  std::int32_t* cost;                // [group][ascan][band]
  int first;
  int bscans;
  SegmentationParams p;
};

// The band's origin (origin_of(a), its state 0's depth) of each of the block's columns, noted in
// the job for the search and kept in `origins` for the block; 0 past the B-scan's last A-scan.
template <class OriginOf>
__device__ void band_origins(const BandCostJob& job, int g, int first_column, std::int32_t* origins,
                             OriginOf origin_of) {
  if (threadIdx.x >= kColumnsPerCostBlock) return;
  const int a = first_column + static_cast<int>(threadIdx.x);
  std::int32_t o = 0;
  if (a < job.p.ascans) {
    o = origin_of(a);
    job.origin[static_cast<std::size_t>(g) * job.p.ascans + a] = o;
  }
  origins[threadIdx.x] = o;
}

// Every cost of the block's columns' bands into the job: cost_of(k, s) for column k's state s
// where its depth lies in the image, kOutsideCost where it does not (as ilm_cost and rpe_cost).
template <class CostOf>
__device__ void band_costs(const BandCostJob& job, int g, int first_column, int columns,
                           const std::int32_t* origins, CostOf cost_of) {
  const SegmentationParams& p = job.p;
  for (int i = threadIdx.x; i < columns * p.band; i += blockDim.x) {
    const int k = i / p.band;
    const int s = i % p.band;
    const int d = origins[k] + s;
    job.cost[(static_cast<std::size_t>(g) * p.ascans + first_column + k) * p.band + s] =
        d >= 0 && d < p.depth ? cost_of(k, s) : detail::kOutsideCost;
  }
}

// The levels (above the background) of the block's columns of B-scan b over their windows: from
// `before` px above each band's origin, `length` px, the edge px repeated outside the column (as
// px() does); column k's level x goes to into[k * row + offset + x].
template <class Level>
__device__ void window_levels(const std::uint8_t* volume, const SegmentationParams& p, int b,
                              int first_column, int columns, const std::int32_t* origins,
                              int before, int length, int floor, Level* into, int row, int offset) {
  const std::uint8_t* pixels = volume + static_cast<std::size_t>(b) * p.ascans * p.depth;
  for (int i = threadIdx.x; i < columns * length; i += blockDim.x) {
    const int k = i / length;
    const int x = i % length;
    const std::uint8_t* column = pixels + static_cast<std::size_t>(first_column + k) * p.depth;
    const int d = origins[k] - before + x;
    into[k * row + offset + x] = static_cast<Level>(
        detail::above_floor(__ldg(column + detail::clamp_int(d, 0, p.depth - 1)), floor));
  }
}

// The RPE band's costs from each column's levels (above the background) over the band and its
// windows' reach, worked out once into shared memory: a cost then reads levels, not px with
// their clamps and background. Shared memory: per column of the block, rpe_window_length(band)
// levels.
constexpr int kRpeWindowBefore = detail::kRpeAboveLast;  // px of the window above state 0
constexpr int kRpeWindowAfter = detail::kRpeBelowLast;   // and below the band's last state
__host__ __device__ constexpr int rpe_window_length(int band) {
  return kRpeWindowBefore + band + kRpeWindowAfter;
}

__global__ void rpe_cost_kernel(BandCostJob job) {
  extern __shared__ __align__(16) std::uint8_t levels[];  // [kColumnsPerCostBlock][length]
  __shared__ std::int32_t origins[kColumnsPerCostBlock];
  const SegmentationParams& p = job.p;
  const int g = blockIdx.y;
  const int b = job.first + g;
  const int first_column = blockIdx.x * kColumnsPerCostBlock;
  const int columns = min(kColumnsPerCostBlock, p.ascans - first_column);
  const int length = rpe_window_length(p.band);
  band_origins(job, g, first_column, origins,
               [&](int a) { return job.ilm_px[static_cast<std::size_t>(g) * p.ascans + a]; });
  __syncthreads();
  const int floor = job.floors[b];
  window_levels(job.volume, p, b, first_column, columns, origins, kRpeWindowBefore, length, floor,
                levels, length, 0);
  __syncthreads();
  band_costs(job, g, first_column, columns, origins, [&](int k, int s) {
    const std::uint8_t* at = levels + k * length + kRpeWindowBefore + s;  // d's level
    int above = 0;
#pragma unroll
    for (int j = detail::kRpeAboveFirst; j <= detail::kRpeAboveLast; ++j) {
      above = max(above, static_cast<int>(at[-j]));
    }
    int below = 0;
#pragma unroll
    for (int j = detail::kRpeBelowFirst; j <= detail::kRpeBelowLast; ++j) {
      below = max(below, static_cast<int>(at[j]));
    }
    return detail::rpe_cost_of_score(detail::rpe_score_of_levels(at[0], above, below), s,
                                     p.rpe_depth_cap);
  });
}

// The ILM band's costs from prefix sums: every cost of the band is three sums of levels over
// windows of up to 12 px (ilm_score), so each column's levels over the band and the windows'
// reach are summed once (a warp scan) and every cost takes its sums as differences: the same
// integers as ilm_cost's px-by-px sums, in a fraction of the reads. Shared memory: per column of
// the block, the prefix sums (ilm_window_length(band) + 1 ints, the first 0).
constexpr int kIlmWindowBefore = detail::kIlmAboveLast;  // px of the window above state 0
constexpr int kIlmWindowAfter = detail::kIlmBelowLast;   // and below the band's last state
static_assert(kIlmWindowBefore >= detail::kIlmRiseAbove &&
              kIlmWindowAfter >= detail::kIlmRiseBelow);
__host__ __device__ constexpr int ilm_window_length(int band) {
  return kIlmWindowBefore + band + kIlmWindowAfter;
}

__global__ void ilm_cost_kernel(BandCostJob job) {
  extern __shared__ __align__(16) std::int32_t prefix[];  // [kColumnsPerCostBlock][length + 1]
  __shared__ std::int32_t origins[kColumnsPerCostBlock];
  const SegmentationParams& p = job.p;
  const int g = blockIdx.y;
  const int b = job.first + g;
  const int first_column = blockIdx.x * kColumnsPerCostBlock;
  const int columns = min(kColumnsPerCostBlock, p.ascans - first_column);
  const int length = ilm_window_length(p.band);
  const int stride = length + 1;
  band_origins(job, g, first_column, origins, [&](int a) {
    const std::int32_t* own = job.coarse + static_cast<std::size_t>(b) * p.ascans;
    const bool has_before = b > 0 && job.coarse_valid[b - 1] != 0;
    const bool has_after = b + 1 < job.bscans && job.coarse_valid[b + 1] != 0;
    const std::int32_t before = has_before ? own[a - p.ascans] : own[a];
    const std::int32_t after = has_after ? own[a + p.ascans] : own[a];
    return detail::ilm_band_origin(detail::median3(before, own[a], after), p.band);
  });
  __syncthreads();
  const int floor = job.floors[b];
  window_levels(job.volume, p, b, first_column, columns, origins, kIlmWindowBefore, length, floor,
                prefix, stride, 1);
  __syncthreads();
  // Each column's inclusive scan, a warp per column, 32 levels at a time.
  using WarpScan = cub::WarpScan<std::int32_t>;
  __shared__ typename WarpScan::TempStorage scan_storage[kCostThreads / 32];
  const int warp = static_cast<int>(threadIdx.x / 32);
  const int lane = static_cast<int>(threadIdx.x % 32);
  for (int k = warp; k < columns; k += kCostThreads / 32) {
    std::int32_t* sums = prefix + k * stride;
    if (lane == 0) sums[0] = 0;
    std::int32_t carry = 0;
    for (int x0 = 0; x0 < length; x0 += 32) {
      const int x = x0 + lane;
      std::int32_t value = x < length ? sums[1 + x] : 0;
      std::int32_t total = 0;
      WarpScan(scan_storage[warp]).InclusiveSum(value, value, total);
      if (x < length) sums[1 + x] = carry + value;
      carry += total;
      __syncwarp();
    }
  }
  __syncthreads();
  // Each cost from its sums: sum(first, last) holds the levels from d + first to d + last.
  band_costs(job, g, first_column, columns, origins, [&](int k, int s) {
    const std::int32_t* sums = prefix + k * stride;
    const int at = kIlmWindowBefore + s;  // d's index in the window
    const auto sum = [&](int first, int last) { return sums[at + last + 1] - sums[at + first]; };
    const int rise = sum(0, detail::kIlmRiseBelow) - sum(-detail::kIlmRiseAbove, -1);
    const int above = sum(-detail::kIlmAboveLast, -detail::kIlmAboveFirst);
    const int below = sum(detail::kIlmBelowFirst, detail::kIlmBelowLast);
    return detail::ilm_cost_of_score(detail::ilm_score_of_sums(rise, above, below));
  });
}

// ---------------------------------------------------------------------------------------------
// Finishing: smoothing and bridging of every A-scan of the affected B-scans.

struct FinishJob {
  detail::RawFits raw;
  detail::RememberedFits remembered;
  detail::FinishSettings settings;
  float* ilm;
  float* rpe;
  float* finished_bm;  // before Bruch's membrane is looked for beneath lifted RPE
  float* confidence;
  SurfaceState* state;
  detail::FinishedKind* finished_kind;
  BscanVerdict* verdict;
  int first;        // first output B-scan
  int group_first;  // the group's B-scans
  int group_end;
};

// Whether each fit of B-scans first, first + 1, ... counts as measured (finishing.hpp,
// RawFits::measured): a thread per A-scan.
__global__ void measured_kernel(detail::RawFits raw, detail::FinishSettings settings,
                                std::uint8_t* measured, int first) {
  const int b = first + static_cast<int>(blockIdx.y);
  const int a = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  if (a >= raw.ascans) return;
  measured[static_cast<std::size_t>(b) * raw.ascans + a] =
      detail::measured_from_fits(raw, settings, b, a) ? 1 : 0;
}

__global__ void finish_kernel(FinishJob job) {
  const int b = job.first + blockIdx.y;
  const int a = blockIdx.x * blockDim.x + threadIdx.x;
  if (a == 0) job.verdict[b] = static_cast<BscanVerdict>(job.raw.verdict[b]);
  if (a >= job.raw.ascans) return;
  // A measured A-scan is smoothed over the B-scans beside it, which count as measured by the
  // fits kAcrossCheckBscans beyond them: further from the group it cannot have changed (only
  // bridges reach further).
  constexpr int kReach = 1 + detail::kAcrossCheckBscans;
  if ((b < job.group_first - kReach || b > job.group_end - 1 + kReach) &&
      detail::is_measured(job.raw, b, a)) {
    return;
  }
  const detail::FinishedAscan f = detail::finish_ascan(job.raw, job.remembered, job.settings, b, a);
  const std::size_t k = static_cast<std::size_t>(b) * job.raw.ascans + a;
  job.ilm[k] = f.ilm;
  job.rpe[k] = f.rpe;
  job.finished_bm[k] = f.bm;
  job.confidence[k] = f.confidence;
  job.state[k] = f.state;
  job.finished_kind[k] = f.kind;
}

// ---------------------------------------------------------------------------------------------
// Bruch's membrane beneath a lifted RPE (lifted_rpe.hpp), after the finishing: a block per
// finished B-scan, its smoothed BM and floor in shared memory through the clipping passes.

struct MembraneJob {
  const float* finished_bm;  // [bscan][ascan], as the finishing left it
  float* bm;                 // the surfaces
  int first;                 // first output B-scan
  int ascans;
  detail::MembraneSettings settings;
};

__global__ void membrane_kernel(MembraneJob job) {
  // [3][ascans]: the finished BM (then the next floor), the smoothed BM, the floor. The row is read
  // once, coalesced; the medians' windows then come from shared memory.
  extern __shared__ float scratch[];
  const int n = job.ascans;
  const std::size_t row = static_cast<std::size_t>(job.first + blockIdx.x) * n;
  float* finished = scratch;
  float* smoothed = scratch + n;
  float* bm_floor = scratch + 2 * n;
  for (int a = threadIdx.x; a < n; a += blockDim.x) finished[a] = job.finished_bm[row + a];
  __syncthreads();
  for (int a = threadIdx.x; a < n; a += blockDim.x) {
    const float v = detail::bm_median_at(finished, n, a, job.settings.median_reach);
    smoothed[a] = v;
    bm_floor[a] = v;
  }
  __syncthreads();
  float* next_floor = finished;  // the finished BM is read from global memory at the end
  for (int p = 1; p <= job.settings.clip_reach; ++p) {
    for (int a = threadIdx.x; a < n; a += blockDim.x) {
      next_floor[a] = detail::clipped_at(bm_floor, n, a, p);
    }
    __syncthreads();  // the next pass writes where this one read
    float* t = bm_floor;
    bm_floor = next_floor;
    next_floor = t;
  }
  float* bm = job.bm + row;
  for (int a = threadIdx.x; a < n; a += blockDim.x) {
    bm[a] = detail::membrane_at(job.finished_bm[row + a], smoothed[a], bm_floor[a],
                                job.settings.lift_px);
  }
}

// The search kernels by step bound: [0] any bound, [k] a bound of k px (or cells); for blocks of
// up to kSearchThreads threads and of up to 1024.
constexpr int kFixedSteps = detail::kMaxKeyedStep;
template <int kMaxThreads>
constexpr std::array<void (*)(PathJob), kFixedSteps + 1> kPathKernels = {
    path_kernel<0, kMaxThreads>, path_kernel<1, kMaxThreads>, path_kernel<2, kMaxThreads>,
    path_kernel<3, kMaxThreads>, path_kernel<4, kMaxThreads>, path_kernel<5, kMaxThreads>,
    path_kernel<6, kMaxThreads>, path_kernel<7, kMaxThreads>, path_kernel<8, kMaxThreads>};

// Why this build's kernels cannot run on the current device, or cudaSuccess.
cudaError_t probe_kernels() {
  cudaFuncAttributes attributes;
  return cudaFuncGetAttributes(&attributes, path_kernel<0, 1024>);
}

}  // namespace

struct CudaSegmenter::DeviceState {
  std::uint32_t bscans = 0;
  std::uint32_t ascans = 0;
  std::uint32_t depth = 0;
  SegmentationParams params;
  std::size_t max_steps_shared = 0;
  cuda::DeviceArray<std::uint8_t> volume;  // host volumes are copied here
  // Memory of the volume.
  cuda::DeviceArray<std::int32_t> coarse;
  cuda::DeviceArray<std::uint8_t> coarse_valid, floors;
  cuda::DeviceArray<std::uint8_t> raw_verdict;  // BscanVerdict values, as the kernels write them
  cuda::DeviceArray<float> raw_ilm, raw_rpe, raw_bm, raw_confidence;
  cuda::DeviceArray<detail::CycleClock> clock;  // one
  cuda::DeviceArray<std::uint32_t> fits_cycle;  // [bscan]
  cuda::DeviceArray<float> remembered_ilm, remembered_rpe, remembered_bm;
  cuda::DeviceArray<std::uint32_t> remembered_frame_cycle, remembered_measured_cycle;
  // (The surfaces are the finished values, but for the BM, looked for beneath lifted RPE.)
  cuda::DeviceArray<detail::FinishedKind> finished_kind;
  cuda::DeviceArray<float> finished_bm;
  cuda::DeviceArray<std::uint8_t> measured;  // [bscan][ascan] (RawFits::measured), scratch
  // Surfaces.
  cuda::DeviceArray<float> ilm, rpe, bm, confidence;
  cuda::DeviceArray<SurfaceState> state;
  cuda::DeviceArray<BscanVerdict> verdict;
  // download_surfaces' way to the host.
  cuda::PinnedDownload surfaces_download;
  // Scratch of one group (sized for a whole volume).
  cuda::DeviceArray<std::uint32_t> histograms;
  cuda::DeviceArray<std::int32_t> coarse_cost, coarse_path, band_origin, band_cost, ilm_px, rpe_px;
  // Empty (null) unless the search steps do not fit in shared memory.
  cuda::DeviceArray<std::int8_t> global_steps;
  cuda::DeviceArray<std::uint8_t> contrasts;
  int histogram_blocks = 0;  // coarse cost blocks per B-scan
  // The groups' launches captured as CUDA graphs, by volume, group and stream.
  std::map<std::tuple<const void*, std::uint32_t, std::uint32_t, cudaStream_t>, cudaGraphExec_t>
      graphs;

  // Nothing segmented: every B-scan holds what one not segmented yet holds on the host
  // (Surfaces::reset: NaN surfaces, confidence 0, state none, verdict not_segmented; the search
  // and fit memory as VolumeMemory::reset clears it). The renderer and a download of the whole
  // volume read B-scans before a cycle reaches them.
  void clear_surfaces(cudaStream_t stream) {
    const std::size_t n = static_cast<std::size_t>(bscans) * ascans;
    for (auto* bytes : {&coarse_valid, &raw_verdict, &floors}) {
      IOCT_CUDA_CHECK(cudaMemsetAsync(bytes->data(), 0, bscans, stream));
    }
    IOCT_CUDA_CHECK(cudaMemsetAsync(verdict.data(), 0, bscans * sizeof(BscanVerdict), stream));
    IOCT_CUDA_CHECK(cudaMemsetAsync(state.data(), 0, n * sizeof(SurfaceState), stream));  // none
    for (auto* surface : {&ilm, &rpe, &bm}) {
      IOCT_CUDA_CHECK(cudaMemsetAsync(surface->data(), 0xFF, n * sizeof(float), stream));  // NaN
    }
    for (auto* zero : {&confidence, &raw_ilm, &raw_rpe, &raw_bm, &raw_confidence, &finished_bm}) {
      IOCT_CUDA_CHECK(cudaMemsetAsync(zero->data(), 0, n * sizeof(float), stream));
    }
    IOCT_CUDA_CHECK(cudaMemsetAsync(coarse.data(), 0, n * sizeof(std::int32_t), stream));
  }

  // No cycle so far, nothing remembered (a zero CycleClock is its initial state; the rest is
  // cleared as the CPU's memory is, for download_memory, except the finished ILM and RPE, which
  // are the surfaces themselves here: NaN where the host's memory holds 0, read by no one while
  // their kind is none).
  void forget_cycles(cudaStream_t stream) {
    const std::size_t n = static_cast<std::size_t>(bscans) * ascans;
    IOCT_CUDA_CHECK(cudaMemsetAsync(clock.data(), 0, sizeof(detail::CycleClock), stream));
    IOCT_CUDA_CHECK(cudaMemsetAsync(fits_cycle.data(), 0, bscans * sizeof(std::uint32_t), stream));
    IOCT_CUDA_CHECK(cudaMemsetAsync(finished_kind.data(), 0, n, stream));
    for (auto* slots : {&remembered_ilm, &remembered_rpe, &remembered_bm}) {
      IOCT_CUDA_CHECK(cudaMemsetAsync(slots->data(), 0, n * sizeof(float), stream));
    }
    for (auto* cycles : {&remembered_frame_cycle, &remembered_measured_cycle}) {
      IOCT_CUDA_CHECK(cudaMemsetAsync(cycles->data(), 0, n * sizeof(std::uint32_t), stream));
    }
  }

  void destroy_graphs() noexcept {
    for (auto& [key, graph] : graphs) cudaGraphExecDestroy(graph);
    graphs.clear();
  }
};

namespace {

template <class T>
cuda::DeviceArray<T> device_array(std::size_t count) {
  return cuda::DeviceArray<T>(std::max<std::size_t>(count, 1));
}

int round_up_warp(int n) {
  return (n + 31) / 32 * 32;
}

// Shared memory of a search: rows, origins (padded to 8 bytes), 32 keys, and the steps if they fit.
std::size_t path_shared_bytes(int columns, int states, int row_pad, bool steps) {
  std::size_t bytes = 4 * static_cast<std::size_t>(states + 2 * row_pad) * sizeof(std::int32_t) +
                      static_cast<std::size_t>(columns + (columns & 1)) * sizeof(std::int32_t) +
                      32 * sizeof(unsigned long long);
  if (steps) bytes += static_cast<std::size_t>(columns) * states;
  return bytes;
}

}  // namespace

std::string cuda_segmentation_problem() {
  int devices = 0;
  if (const cudaError_t status = cudaGetDeviceCount(&devices); status != cudaSuccess) {
    cudaGetLastError();
    return std::string("no CUDA device: ") + cudaGetErrorName(status) + " (" +
           cudaGetErrorString(status) + ")";
  }
  if (devices == 0) return "no CUDA device is present";
  if (const cudaError_t status = probe_kernels(); status != cudaSuccess) {
    cudaGetLastError();
    return std::string("this build's kernels cannot run on device 0: ") + cudaGetErrorName(status) +
           " (" + cudaGetErrorString(status) + ")";
  }
  return {};
}

CudaSegmenter::CudaSegmenter(const SegmentationConfig& config, const VolumeSampling& sampling)
    : config_((config.validate(), config)), sampling_((sampling.validate(), sampling)) {
  if (const std::string problem = cuda_segmentation_problem(); !problem.empty()) {
    throw BackendUnavailable("backend cuda: " + problem);
  }
  IOCT_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
  IOCT_CUDA_CHECK(cudaEventCreateWithFlags(&resets_done_, cudaEventDisableTiming));
  int device = 0;
  IOCT_CUDA_CHECK(cudaGetDevice(&device));
  int optin = 0;
  IOCT_CUDA_CHECK(cudaDeviceGetAttribute(&optin, cudaDevAttrMaxSharedMemoryPerBlockOptin, device));
  std::size_t dynamic_limit = static_cast<std::size_t>(optin);
  for (const auto& kernels : {kPathKernels<kSearchThreads>, kPathKernels<1024>}) {
    for (const auto kernel : kernels) {
      // What the kernel's own (static) shared memory leaves of the block's.
      cudaFuncAttributes attributes{};
      IOCT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, kernel));
      const int dynamic = optin - static_cast<int>(attributes.sharedSizeBytes);
      IOCT_CUDA_CHECK(
          cudaFuncSetAttribute(kernel, cudaFuncAttributeMaxDynamicSharedMemorySize, dynamic));
      dynamic_limit = std::min(dynamic_limit, static_cast<std::size_t>(dynamic));
    }
  }
  state_ = std::make_unique<DeviceState>();
  // The steps go to shared memory when they fit beside the rows and origins (at most 4 x (256 +
  // 2 x kStepKeyPad) + 4096 int32 and 32 keys: 20.8 kB).
  state_->max_steps_shared = std::min<std::size_t>(dynamic_limit - 21 * 1024, kSharedStepsLimit);
}

CudaSegmenter::~CudaSegmenter() {
  if (state_) state_->destroy_graphs();
  state_.reset();
  if (resets_done_ != nullptr) cudaEventDestroy(resets_done_);
  if (stream_ != nullptr) cudaStreamDestroy(stream_);
}

void CudaSegmenter::note_resets() {
  IOCT_CUDA_CHECK(cudaEventRecord(resets_done_, stream_));
  resets_pending_ = true;
}

void CudaSegmenter::forget() {
  DeviceState& d = *state_;
  if (d.bscans == 0) return;
  d.clear_surfaces(stream_);
  d.forget_cycles(stream_);
  note_resets();
}

void CudaSegmenter::prepare(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth) {
  DeviceState& d = *state_;
  const SegmentationParams params = make_params(config_, sampling_, depth, ascans);
  if (d.bscans == bscans && d.ascans == ascans && d.depth == depth) {
    d.params = params;
    return;
  }
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream_));
  const std::size_t n = static_cast<std::size_t>(bscans) * ascans;
  const std::size_t band_states = static_cast<std::size_t>(params.band);
  const std::size_t max_steps_shared = d.max_steps_shared;
  d.destroy_graphs();
  d = DeviceState{};
  d.max_steps_shared = max_steps_shared;
  d.params = params;
  d.volume = device_array<std::uint8_t>(n * depth);
  d.coarse = device_array<std::int32_t>(n);
  d.coarse_valid = device_array<std::uint8_t>(bscans);
  d.floors = device_array<std::uint8_t>(bscans);
  d.raw_ilm = device_array<float>(n);
  d.raw_rpe = device_array<float>(n);
  d.raw_bm = device_array<float>(n);
  d.raw_confidence = device_array<float>(n);
  d.raw_verdict = device_array<std::uint8_t>(bscans);
  d.clock = device_array<detail::CycleClock>(1);
  d.fits_cycle = device_array<std::uint32_t>(bscans);
  d.remembered_ilm = device_array<float>(n);
  d.remembered_rpe = device_array<float>(n);
  d.remembered_bm = device_array<float>(n);
  d.remembered_frame_cycle = device_array<std::uint32_t>(n);
  d.remembered_measured_cycle = device_array<std::uint32_t>(n);
  d.finished_kind = device_array<detail::FinishedKind>(n);
  d.finished_bm = device_array<float>(n);
  d.measured = device_array<std::uint8_t>(n);
  d.ilm = device_array<float>(n);
  d.rpe = device_array<float>(n);
  d.bm = device_array<float>(n);
  d.confidence = device_array<float>(n);
  d.state = device_array<SurfaceState>(n);
  d.verdict = device_array<BscanVerdict>(bscans);
  d.histogram_blocks = (params.coarse_columns + kPairsPerCostBlock - 1) / kPairsPerCostBlock;
  d.histograms = device_array<std::uint32_t>(static_cast<std::size_t>(bscans) * d.histogram_blocks *
                                             kHistogramBins);
  d.coarse_cost = device_array<std::int32_t>(static_cast<std::size_t>(bscans) *
                                             params.coarse_columns * params.coarse_cells);
  d.coarse_path =
      device_array<std::int32_t>(static_cast<std::size_t>(bscans) * params.coarse_columns);
  d.band_origin = device_array<std::int32_t>(n);
  d.band_cost = device_array<std::int32_t>(n * band_states);
  d.ilm_px = device_array<std::int32_t>(n);
  d.rpe_px = device_array<std::int32_t>(n);
  const std::size_t coarse_steps =
      static_cast<std::size_t>(params.coarse_columns) * params.coarse_cells;
  const std::size_t fine_steps = static_cast<std::size_t>(ascans) * band_states;
  if (std::max(coarse_steps, fine_steps) > d.max_steps_shared) {
    d.global_steps = device_array<std::int8_t>(static_cast<std::size_t>(bscans) *
                                               std::max(coarse_steps, fine_steps));
  }
  d.contrasts = device_array<std::uint8_t>(3 * n);
  d.bscans = bscans;
  d.ascans = ascans;
  d.depth = depth;
  d.clear_surfaces(stream_);
  d.forget_cycles(stream_);
  note_resets();
}

namespace {

void launch_path(const PathJob& job, int count, std::size_t max_steps_shared, cudaStream_t stream) {
  PathJob j = job;
  const std::size_t steps = static_cast<std::size_t>(j.columns) * j.states;
  j.shared_steps = steps <= max_steps_shared;
  j.half_threads = round_up_warp(j.states);
  const int fixed_step = j.max_step <= kFixedSteps ? j.max_step : 0;
  const int row_pad = fixed_step > 0 ? detail::kStepKeyPad : 0;
  const std::size_t shared = path_shared_bytes(j.columns, j.states, row_pad, j.shared_steps);
  const int threads = 2 * j.half_threads;
  const auto kernel = threads <= kSearchThreads ? kPathKernels<kSearchThreads>[fixed_step]
                                                : kPathKernels<1024>[fixed_step];
  kernel<<<count, threads, shared, stream>>>(j);
  cuda::check_launch("path_kernel");
}

}  // namespace

BscanSpan CudaSegmenter::enqueue_group(const std::uint8_t* device_volume, BscanSpan group,
                                       cudaStream_t stream) {
  DeviceState& d = *state_;
  check_group_span(group, d.bscans);
  // The legacy default stream cannot be captured, a stream being captured by the caller is
  // recorded into the caller's graph as it is, and stage events go around the graph.
  cudaStreamCaptureStatus capturing = cudaStreamCaptureStatusNone;
  if (stream != nullptr) {
    IOCT_CUDA_CHECK(cudaStreamIsCapturing(stream, &capturing));
  }
  // The resets of prepare() and forget() run on the segmenter's own stream: the caller's waits
  // for them (a stream being captured cannot wait on an event from outside its graph: its
  // capture must begin after them).
  if (resets_pending_ && capturing == cudaStreamCaptureStatusNone) {
    IOCT_CUDA_CHECK(cudaStreamWaitEvent(stream, resets_done_, 0));
    resets_pending_ = false;
  }
  if (!use_graphs_ || stage_events_ != nullptr || stream == nullptr ||
      capturing != cudaStreamCaptureStatusNone) {
    return enqueue_direct(device_volume, group, stream);
  }
  const auto key =
      std::make_tuple(static_cast<const void*>(device_volume), group.first, group.count, stream);
  auto found = d.graphs.find(key);
  if (found == d.graphs.end()) {
    cudaGraph_t graph = nullptr;
    IOCT_CUDA_CHECK(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal));
    try {
      enqueue_direct(device_volume, group, stream);
    } catch (...) {
      cudaStreamEndCapture(stream, &graph);
      if (graph != nullptr) cudaGraphDestroy(graph);
      throw;
    }
    IOCT_CUDA_CHECK(cudaStreamEndCapture(stream, &graph));
    cudaGraphExec_t exec = nullptr;
    const cudaError_t status = cudaGraphInstantiate(&exec, graph, 0);
    cudaGraphDestroy(graph);
    cuda::check(status, "cudaGraphInstantiate");
    found = d.graphs.emplace(key, exec).first;
  }
  IOCT_CUDA_CHECK(cudaGraphLaunch(found->second, stream));
  return outputs_affected(group, d.bscans);
}

void CudaSegmenter::check_group_span(BscanSpan group, std::uint32_t bscans) {
  if (group.count == 0 || group.first >= bscans || group.count > bscans - group.first) {
    throw std::out_of_range("segmentation: B-scans [" + std::to_string(group.first) + ", " +
                            std::to_string(std::uint64_t{group.first} + group.count) +
                            ") are not a group of the volume of " + std::to_string(bscans) +
                            " B-scans");
  }
}

BscanSpan CudaSegmenter::enqueue_direct(const std::uint8_t* device_volume, BscanSpan group,
                                        cudaStream_t stream) {
  DeviceState& d = *state_;
  if (group.count == 0 || group.first >= d.bscans || group.count > d.bscans - group.first) {
    throw std::out_of_range("segmentation: B-scans [" + std::to_string(group.first) + ", " +
                            std::to_string(std::uint64_t{group.first} + group.count) +
                            ") are not a group of the volume of " + std::to_string(d.bscans) +
                            " B-scans");
  }
  const SegmentationParams& p = d.params;
  int stage = 0;
  const auto stage_done = [&] {
    if (stage_events_ != nullptr) {
      IOCT_CUDA_CHECK(cudaEventRecord(stage_events_[stage], stream));
    }
    ++stage;
  };
  const int count = static_cast<int>(group.count);
  const int first = static_cast<int>(group.first);
  {
    const CoarseCostJob job{
        device_volume, d.histograms.data(), d.coarse_cost.data(), d.clock.data(), first, p};
    const dim3 grid(
        static_cast<unsigned>((p.coarse_columns + kPairsPerCostBlock - 1) / kPairsPerCostBlock),
        static_cast<unsigned>(count));
    const std::size_t shared = static_cast<std::size_t>(kPairsPerCostBlock) * kCoarsePair *
                               (static_cast<std::size_t>(p.depth) + p.coarse_cells);
    coarse_cost_kernel<<<grid, kCostThreads, shared, stream>>>(job);
    cuda::check_launch("coarse_cost_kernel");
  }
  stage_done();
  {
    PathJob job{};
    job.cost = d.coarse_cost.data();
    job.origin = nullptr;
    job.path = d.coarse_path.data();
    job.global_steps = d.global_steps.data();
    job.histograms = d.histograms.data();
    job.histogram_blocks = d.histogram_blocks;
    job.coarse = d.coarse.data();
    job.coarse_valid = d.coarse_valid.data();
    job.floors = d.floors.data();
    job.first = first;
    job.p = p;
    job.columns = p.coarse_columns;
    job.states = p.coarse_cells;
    job.max_step = p.coarse_step;
    job.penalty = p.coarse_step_penalty;
    job.stage = PathStage::coarse;
    launch_path(job, count, d.max_steps_shared, stream);
  }
  stage_done();
  const dim3 band_grid(
      static_cast<unsigned>((p.ascans + kColumnsPerCostBlock - 1) / kColumnsPerCostBlock),
      static_cast<unsigned>(count));
  const std::size_t rpe_shared =
      static_cast<std::size_t>(kColumnsPerCostBlock) * rpe_window_length(p.band);
  const std::size_t ilm_shared = static_cast<std::size_t>(kColumnsPerCostBlock) *
                                 (ilm_window_length(p.band) + 1) * sizeof(std::int32_t);
  for (const bool rpe : {false, true}) {
    const BandCostJob job{device_volume,
                          d.floors.data(),
                          d.coarse.data(),
                          d.coarse_valid.data(),
                          d.ilm_px.data(),
                          d.band_origin.data(),
                          d.band_cost.data(),
                          first,
                          static_cast<int>(d.bscans),
                          p};
    if (rpe) {
      rpe_cost_kernel<<<band_grid, kCostThreads, rpe_shared, stream>>>(job);
      cuda::check_launch("rpe_cost_kernel");
    } else {
      ilm_cost_kernel<<<band_grid, kCostThreads, ilm_shared, stream>>>(job);
      cuda::check_launch("ilm_cost_kernel");
    }
    stage_done();
    PathJob path{};
    path.cost = d.band_cost.data();
    path.origin = d.band_origin.data();
    path.path = rpe ? d.rpe_px.data() : d.ilm_px.data();
    path.global_steps = d.global_steps.data();
    path.first = first;
    path.p = p;
    path.columns = p.ascans;
    path.states = p.band;
    path.max_step = p.max_step;
    path.penalty = p.step_penalty;
    path.stage = rpe ? PathStage::rpe : PathStage::ilm;
    launch_path(path, count, d.max_steps_shared, stream);
    stage_done();
  }
  {
    FitJob job{};
    job.volume = device_volume;
    job.floors = d.floors.data();
    job.ilm_px = d.ilm_px.data();
    job.rpe_px = d.rpe_px.data();
    job.ilm = d.raw_ilm.data();
    job.rpe = d.raw_rpe.data();
    job.bm = d.raw_bm.data();
    job.confidence = d.raw_confidence.data();
    job.verdict = d.raw_verdict.data();
    job.contrasts = d.contrasts.data();
    job.clock = d.clock.data();
    job.fits_cycle = d.fits_cycle.data();
    job.finished_kind = d.finished_kind.data();
    job.finished_ilm = d.ilm.data();
    job.finished_rpe = d.rpe.data();
    job.finished_bm = d.finished_bm.data();
    job.remembered = {d.remembered_ilm.data(), d.remembered_rpe.data(), d.remembered_bm.data(),
                      d.remembered_frame_cycle.data(), d.remembered_measured_cycle.data()};
    job.first = first;
    job.p = p;
    const dim3 grid(static_cast<unsigned>((p.ascans + kFitThreads - 1) / kFitThreads),
                    static_cast<unsigned>(count));
    fit_kernel<<<grid, kFitThreads, 0, stream>>>(job);
    cuda::check_launch("fit_kernel");
    verdict_kernel<<<count, kVerdictThreads, 0, stream>>>(job);
    cuda::check_launch("verdict_kernel");
  }
  stage_done();
  const BscanSpan outputs = outputs_affected(group, d.bscans);
  {
    FinishJob job{};
    job.raw =
        detail::RawFits{d.raw_ilm.data(),           d.raw_rpe.data(),          d.raw_bm.data(),
                        d.raw_confidence.data(),    d.raw_verdict.data(),      d.measured.data(),
                        static_cast<int>(d.bscans), static_cast<int>(d.ascans)};
    job.remembered = {d.remembered_ilm.data(),
                      d.remembered_rpe.data(),
                      d.remembered_bm.data(),
                      d.remembered_frame_cycle.data(),
                      d.remembered_measured_cycle.data(),
                      d.fits_cycle.data()};
    job.settings = detail::FinishSettings{p.min_confidence,
                                          p.smooth_tolerance_px,
                                          static_cast<float>(sampling_.ascan_spacing_um),
                                          static_cast<float>(sampling_.bscan_spacing_um),
                                          p.bridge_bscans,
                                          p.smooth};
    job.ilm = d.ilm.data();
    job.rpe = d.rpe.data();
    job.finished_bm = d.finished_bm.data();
    job.confidence = d.confidence.data();
    job.state = d.state.data();
    job.finished_kind = d.finished_kind.data();
    job.verdict = d.verdict.data();
    job.first = static_cast<int>(outputs.first);
    job.group_first = first;
    job.group_end = first + count;
    // The measured flags the finishing reads, first.
    const detail::MeasuredSpan read =
        detail::measured_span(job.settings, static_cast<int>(outputs.first),
                              static_cast<int>(outputs.end()), static_cast<int>(d.bscans));
    const unsigned ascan_blocks =
        static_cast<unsigned>((p.ascans + kFinishThreads - 1) / kFinishThreads);
    measured_kernel<<<dim3(ascan_blocks, static_cast<unsigned>(read.end - read.first)),
                      kFinishThreads, 0, stream>>>(job.raw, job.settings, d.measured.data(),
                                                   read.first);
    cuda::check_launch("measured_kernel");
    const dim3 grid(ascan_blocks, outputs.count);
    finish_kernel<<<grid, kFinishThreads, 0, stream>>>(job);
    cuda::check_launch("finish_kernel");
    const MembraneJob membrane{
        d.finished_bm.data(), d.bm.data(), static_cast<int>(outputs.first),
        static_cast<int>(d.ascans),
        detail::membrane_settings(sampling_.ascan_spacing_um, sampling_.axial_um_per_px)};
    membrane_kernel<<<outputs.count, kMembraneThreads, 3 * d.ascans * sizeof(float), stream>>>(
        membrane);
    cuda::check_launch("membrane_kernel");
  }
  stage_done();
  return outputs;
}

DeviceSurfaceView CudaSegmenter::device_surfaces() const noexcept {
  const DeviceState& d = *state_;
  return {d.ilm.data(),   d.rpe.data(),     d.bm.data(), d.confidence.data(),
          d.state.data(), d.verdict.data(), d.bscans,    d.ascans};
}

BscanSpan CudaSegmenter::segment_group(const Volume& volume, BscanSpan group, Surfaces& surfaces) {
  check_group_request(volume, group);
  const DeviceState& d = *state_;
  const bool fresh = d.bscans != volume.bscans() || d.ascans != volume.ascans() ||
                     d.depth != volume.depth() || surfaces.bscans != volume.bscans() ||
                     surfaces.ascans != volume.ascans() || surfaces.depth != volume.depth();
  prepare(volume.bscans(), volume.ascans(), volume.depth());
  if (fresh) {
    forget();
    surfaces.reset(volume.bscans(), volume.ascans(), volume.depth());
  }
  const std::size_t bscan_px = volume.bscan_pixels();
  cuda::copy_async(d.volume.data() + group.first * bscan_px, volume.bscan(group.first).data(),
                   group.count * bscan_px, cudaMemcpyHostToDevice, stream_, cuda::Payload::volume,
                   "copy of the group to the device");
  const BscanSpan outputs = enqueue_group(d.volume.data(), group, stream_);
  const std::size_t offset = surfaces.index(outputs.first, 0);
  const std::size_t n = static_cast<std::size_t>(outputs.count) * volume.ascans();
  const auto copy_back = [&]<class T>(T* host, const T* device) {
    cuda::copy_async(host, device + offset, n * sizeof(T), cudaMemcpyDeviceToHost, stream_,
                     cuda::Payload::other, "copy of the surfaces to the host");
  };
  copy_back(surfaces.ilm.data() + offset, d.ilm.data());
  copy_back(surfaces.rpe.data() + offset, d.rpe.data());
  copy_back(surfaces.bm.data() + offset, d.bm.data());
  copy_back(surfaces.confidence.data() + offset, d.confidence.data());
  copy_back(surfaces.state.data() + offset, d.state.data());
  IOCT_CUDA_CHECK(cudaMemcpyAsync(surfaces.verdict.data() + outputs.first,
                                  d.verdict.data() + outputs.first, outputs.count,
                                  cudaMemcpyDeviceToHost, stream_));
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream_));
  return outputs;
}

BscanSpan CudaSegmenter::segment_group(VolumeRef volume, BscanSpan group, Surfaces* surfaces) {
  if (!volume.is_device()) return Segmenter::segment_group(volume, group, surfaces);
  const VolumeDims& dims = volume.dims();
  check_group_request(dims, group);
  const DeviceState& d = *state_;
  if (d.bscans != dims.bscans || d.ascans != dims.ascans || d.depth != dims.depth) {
    // The state is about to be replaced: nothing may still be reading it.
    IOCT_CUDA_CHECK(cudaStreamSynchronize(volume.stream()));
  }
  prepare(dims.bscans, dims.ascans, dims.depth);
  return enqueue_group(volume.device(), group, volume.stream());
}

namespace {

// Surfaces of these dimensions with every array of its size.
bool holds_volume(const Surfaces& s, std::uint32_t bscans, std::uint32_t ascans,
                  std::uint32_t depth) {
  const std::size_t n = std::size_t{bscans} * ascans;
  return s.bscans == bscans && s.ascans == ascans && s.depth == depth && s.ilm.size() == n &&
         s.rpe.size() == n && s.bm.size() == n && s.confidence.size() == n && s.state.size() == n &&
         s.verdict.size() == bscans;
}

}  // namespace

void CudaSegmenter::download_surfaces(Surfaces& surfaces, cudaStream_t stream) {
  const DeviceState& d = *state_;
  if (!holds_volume(surfaces, d.bscans, d.ascans, d.depth)) {
    surfaces.reset(d.bscans, d.ascans, d.depth);
  }
  download_surfaces(surfaces, {0, d.bscans}, stream);
}

void CudaSegmenter::download_surfaces(Surfaces& surfaces, BscanSpan rows, cudaStream_t stream) {
  DeviceState& d = *state_;
  if (!holds_volume(surfaces, d.bscans, d.ascans, d.depth)) {
    throw std::invalid_argument("download_surfaces: host surfaces of " +
                                std::to_string(surfaces.bscans) + " x " +
                                std::to_string(surfaces.ascans) + " A-scans for a volume of " +
                                std::to_string(d.bscans) + " x " + std::to_string(d.ascans));
  }
  if (rows.end() > d.bscans || rows.end() < rows.first) {
    throw std::out_of_range("download_surfaces: B-scans [" + std::to_string(rows.first) + ", " +
                            std::to_string(rows.first + rows.count) + ") outside a volume of " +
                            std::to_string(d.bscans));
  }
  if (rows.count == 0) return;
  const std::size_t offset = static_cast<std::size_t>(rows.first) * d.ascans;
  const std::size_t n = static_cast<std::size_t>(rows.count) * d.ascans;
  const std::size_t floats = n * sizeof(float);
  cuda::PinnedDownload& download = d.surfaces_download;
  download.add(d.ilm.data() + offset, floats);
  download.add(d.rpe.data() + offset, floats);
  download.add(d.bm.data() + offset, floats);
  download.add(d.confidence.data() + offset, floats);
  download.add(d.state.data() + offset, n);
  download.add(d.verdict.data() + rows.first, rows.count);
  download.fetch(stream, cuda::Payload::other, "copy of the surfaces to the host");
  const auto place = [&](std::size_t piece, void* host) {
    const std::span<const std::byte> bytes = download.piece(piece);
    std::memcpy(host, bytes.data(), bytes.size());
  };
  place(0, surfaces.ilm.data() + offset);
  place(1, surfaces.rpe.data() + offset);
  place(2, surfaces.bm.data() + offset);
  place(3, surfaces.confidence.data() + offset);
  static_assert(sizeof(SurfaceState) == 1 && sizeof(BscanVerdict) == 1, "one byte each");
  place(4, surfaces.state.data() + offset);
  place(5, surfaces.verdict.data() + rows.first);
}

void CudaSegmenter::download_memory(VolumeMemory& memory) {
  const DeviceState& d = *state_;
  memory.reset(d.bscans, d.ascans, d.depth);
  const std::size_t n = static_cast<std::size_t>(d.bscans) * d.ascans;
  const auto copy = [&](void* host, const void* device, std::size_t bytes) {
    IOCT_CUDA_CHECK(cudaMemcpyAsync(host, device, bytes, cudaMemcpyDeviceToHost, stream_));
  };
  copy(memory.coarse.data(), d.coarse.data(), n * sizeof(std::int32_t));
  copy(memory.coarse_valid.data(), d.coarse_valid.data(), d.bscans);
  copy(memory.floor.data(), d.floors.data(), d.bscans);
  copy(memory.ilm.data(), d.raw_ilm.data(), n * sizeof(float));
  copy(memory.rpe.data(), d.raw_rpe.data(), n * sizeof(float));
  copy(memory.bm.data(), d.raw_bm.data(), n * sizeof(float));
  copy(memory.confidence.data(), d.raw_confidence.data(), n * sizeof(float));
  copy(memory.verdict.data(), d.raw_verdict.data(), d.bscans);
  copy(memory.finished_ilm.data(), d.ilm.data(), n * sizeof(float));
  copy(memory.finished_rpe.data(), d.rpe.data(), n * sizeof(float));
  copy(memory.finished_bm.data(), d.finished_bm.data(), n * sizeof(float));
  copy(memory.finished_kind.data(), d.finished_kind.data(), n);
  copy(&memory.clock, d.clock.data(), sizeof(detail::CycleClock));
  copy(memory.fits_cycle.data(), d.fits_cycle.data(), d.bscans * sizeof(std::uint32_t));
  copy(memory.remembered_ilm.data(), d.remembered_ilm.data(), n * sizeof(float));
  copy(memory.remembered_rpe.data(), d.remembered_rpe.data(), n * sizeof(float));
  copy(memory.remembered_bm.data(), d.remembered_bm.data(), n * sizeof(float));
  copy(memory.remembered_frame_cycle.data(), d.remembered_frame_cycle.data(),
       n * sizeof(std::uint32_t));
  copy(memory.remembered_measured_cycle.data(), d.remembered_measured_cycle.data(),
       n * sizeof(std::uint32_t));
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream_));
}

}  // namespace ioct::gpu::segmentation
