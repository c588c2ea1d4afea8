#include "cuda_layer_reference.cuh"

#include <cub/block/block_reduce.cuh>

namespace ioct::gpu::render {

namespace {

constexpr int kRowSumThreads = 256;
constexpr int kScalarThreads = 128;
constexpr int kRowThreads = 128;

// One block per B-scan: how many of its A-scans have an RPE value, how many have both surfaces,
// and the sum of their thicknesses. A block per B-scan because the volume's 10^5 A-scans are too
// many for one block (a single block took 0.12 ms on an H100 for the default volume).
__global__ void reference_row_sums_kernel(int ascans, const float* ilm, const float* rpe,
                                          std::uint32_t* has_row, std::uint32_t* row_both,
                                          double* row_thickness) {
  const int b = blockIdx.x;
  const float* ilm_row = ilm + static_cast<std::size_t>(b) * ascans;
  const float* rpe_row = rpe + static_cast<std::size_t>(b) * ascans;
  unsigned any = 0, both = 0;
  double thickness = 0.0;
  for (int a = threadIdx.x; a < ascans; a += blockDim.x) {
    if (isnan(rpe_row[a])) continue;
    ++any;
    if (isnan(ilm_row[a])) continue;
    thickness += static_cast<double>(rpe_row[a] - ilm_row[a]);
    ++both;
  }
  using Count = cub::BlockReduce<unsigned, kRowSumThreads>;
  using SumDouble = cub::BlockReduce<double, kRowSumThreads>;
  __shared__ typename Count::TempStorage count_storage;
  __shared__ typename SumDouble::TempStorage double_storage;
  any = Count(count_storage).Sum(any);
  __syncthreads();
  both = Count(count_storage).Sum(both);
  thickness = SumDouble(double_storage).Sum(thickness);
  if (threadIdx.x != 0) return;
  has_row[b] = any > 0 ? 1 : 0;
  row_both[b] = both;
  row_thickness[b] = thickness;
}

// One block: the centre of mass from the per-B-scan sums, the mean thickness over the A-scans
// having both surfaces, and whether any B-scan has an RPE value, from the rows' sums. Integer and
// (in practice exact) double sums, so the order of the additions does not show.
__global__ void reference_scalars_kernel(const unsigned long long* sums, int bscans, int depth,
                                         const std::uint32_t* has_row,
                                         const std::uint32_t* row_both, const double* row_thickness,
                                         float* scalars) {
  unsigned long long weighted = 0, weight = 0, both = 0, any = 0;
  double thickness = 0.0;
  for (int b = threadIdx.x; b < bscans; b += blockDim.x) {
    weighted += sums[2 * b];
    weight += sums[2 * b + 1];
    if (has_row == nullptr) continue;
    any += has_row[b];
    both += row_both[b];
    thickness += row_thickness[b];
  }
  using Sum64 = cub::BlockReduce<unsigned long long, kScalarThreads>;
  using SumDouble = cub::BlockReduce<double, kScalarThreads>;
  __shared__ typename Sum64::TempStorage storage64;
  __shared__ typename SumDouble::TempStorage storage_double;
  weighted = Sum64(storage64).Sum(weighted);
  __syncthreads();
  weight = Sum64(storage64).Sum(weight);
  __syncthreads();
  both = Sum64(storage64).Sum(both);
  __syncthreads();
  any = Sum64(storage64).Sum(any);
  thickness = SumDouble(storage_double).Sum(thickness);
  if (threadIdx.x != 0) return;
  const float centre =
      weight > 0 ? static_cast<float>(static_cast<double>(weighted) / static_cast<double>(weight))
                 : 0.5f * static_cast<float>(depth);
  float mean = 0.0f;
  if (any > 0 && both > 0 && thickness > 0.0) {
    mean = static_cast<float>(thickness / static_cast<double>(both));
  }
  scalars[0] = mean;
  scalars[1] = centre;
  scalars[2] = any > 0 ? 1.0f : 0.0f;
}

// Entry `i` of a row with its holes filled: the linear interpolation of the nearest values on
// either side, the nearest value past the ends (layer_reference.cpp's fill_row, element-wise).
__device__ float filled(const float* row, int n, int i) {
  if (!isnan(row[i])) return row[i];
  int previous = i - 1;
  while (previous >= 0 && isnan(row[previous])) --previous;
  int next = i + 1;
  while (next < n && isnan(row[next])) ++next;
  if (previous < 0) return row[next];  // the row has a value (has_row)
  if (next >= n) return row[previous];
  const float a = row[previous];
  const float span = static_cast<float>(next - previous);
  return a + (row[next] - a) * static_cast<float>(i - previous) / span;
}

// One block per B-scan: its row of the axial plane, and of the RPE, filled, or the nearest
// B-scan's (the lower one first at equal distance), or the axial plane without any RPE.
__global__ void reference_rows_kernel(int bscans, int ascans, const float* rpe,
                                      const float* scalars, const std::uint32_t* has_row,
                                      float* rpe_out, float* axial_out) {
  const int b = blockIdx.x;
  const float centre = scalars[1];
  float* rpe_row = rpe_out + static_cast<std::size_t>(b) * ascans;
  float* axial_row = axial_out + static_cast<std::size_t>(b) * ascans;
  const bool any = rpe != nullptr && scalars[2] > 0.0f;
  int source = b;
  if (any && has_row[b] == 0) {
    source = -1;
    for (int k = 1; source < 0; ++k) {
      if (b >= k && has_row[b - k] != 0) {
        source = b - k;
      } else if (b + k < bscans && has_row[b + k] != 0) {
        source = b + k;
      }
    }
  }
  const float* row = any ? rpe + static_cast<std::size_t>(source) * ascans : nullptr;
  for (int i = threadIdx.x; i < ascans; i += blockDim.x) {
    axial_row[i] = centre;
    rpe_row[i] = any ? filled(row, ascans, i) : centre;
  }
}

}  // namespace

void DeviceLayerReference::resize(std::uint32_t bscans, std::uint32_t ascans) {
  bscans_ = bscans;
  ascans_ = ascans;
  rpe_.resize(std::size_t{bscans} * ascans);
  axial_.resize(std::size_t{bscans} * ascans);
  scalars_.resize(3);
  has_row_.resize(bscans);
  row_both_.resize(bscans);
  row_thickness_.resize(bscans);
}

void DeviceLayerReference::make(const unsigned long long* sums, std::uint32_t depth,
                                const float* ilm, const float* rpe, cudaStream_t stream) {
  if (bscans_ == 0 || ascans_ == 0) return;
  if (rpe == nullptr || ilm == nullptr) rpe = ilm = nullptr;
  if (rpe != nullptr) {
    reference_row_sums_kernel<<<bscans_, kRowSumThreads, 0, stream>>>(
        static_cast<int>(ascans_), ilm, rpe, has_row_.data(), row_both_.data(),
        row_thickness_.data());
    IOCT_CUDA_CHECK(cudaGetLastError());
  }
  reference_scalars_kernel<<<1, kScalarThreads, 0, stream>>>(
      sums, static_cast<int>(bscans_), static_cast<int>(depth),
      rpe != nullptr ? has_row_.data() : nullptr, row_both_.data(), row_thickness_.data(),
      scalars_.data());
  IOCT_CUDA_CHECK(cudaGetLastError());
  reference_rows_kernel<<<bscans_, kRowThreads, 0, stream>>>(
      static_cast<int>(bscans_), static_cast<int>(ascans_), rpe, scalars_.data(), has_row_.data(),
      rpe_.data(), axial_.data());
  IOCT_CUDA_CHECK(cudaGetLastError());
}

LayerReference DeviceLayerReference::download(cudaStream_t stream) const {
  LayerReference ref;
  ref.bscans = bscans_;
  ref.ascans = ascans_;
  ref.rpe_px.resize(rpe_.size());
  ref.axial_plane_px.resize(axial_.size());
  float scalars[3] = {};
  IOCT_CUDA_CHECK(cudaMemcpyAsync(ref.rpe_px.data(), rpe_.data(), rpe_.bytes(),
                                  cudaMemcpyDeviceToHost, stream));
  IOCT_CUDA_CHECK(cudaMemcpyAsync(ref.axial_plane_px.data(), axial_.data(), axial_.bytes(),
                                  cudaMemcpyDeviceToHost, stream));
  IOCT_CUDA_CHECK(
      cudaMemcpyAsync(scalars, scalars_.data(), sizeof scalars, cudaMemcpyDeviceToHost, stream));
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
  ref.mean_thickness_px = scalars[0];
  return ref;
}

}  // namespace ioct::gpu::render
