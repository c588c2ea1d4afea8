#include <cuda_runtime.h>

#include <cub/warp/warp_reduce.cuh>
#include <cuda/functional>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "cuda_layer_reference.cuh"
#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/cuda/pinned_download.hpp"
#include "ioct/gpu/render/cuda_renderer.hpp"
#include "ioct/gpu/render/frame_setup.hpp"
#include "ioct/gpu/render/la_mip.hpp"
#include "ioct/gpu/render/layer_reference.hpp"
#include "ioct/gpu/render/pixel_shader.hpp"
#include "ioct/gpu/segmentation/cuda_segmenter.hpp"

namespace ioct::gpu::render {

namespace {

constexpr int kBrick = 8;
constexpr int kBrickApron = 2;  // trilinear footprint plus the gradient's central differences

// Trilinear samples from the 3D texture (x: depth, y: A-scan, z: B-scan; unnormalised, centres at
// +0.5). Device only: the host instantiation is never called.
struct TextureSampler {
  cudaTextureObject_t texture;
  __host__ __device__ float operator()(float x, float y, float z) const {
#if defined(__CUDA_ARCH__)
    return tex3D<float>(texture, z + 0.5f, x + 0.5f, y + 0.5f);
#else
    (void)x;
    (void)y;
    (void)z;
    return 0.0f;
#endif
  }
};

// Samples at whole A-scan and B-scan positions, linear in depth, from the linear copy of the
// volume: what the CPU reference's trilinear sampler gives there (its lateral weights are 0),
// from two bytes instead of the texture unit's eight texels. The LA-MIP projections sample only
// there.
struct ColumnSampler {
  const std::uint8_t* voxels;
  int ascans, depth;
  __host__ __device__ float operator()(float x, float y, float z) const {
    const std::uint8_t* column =
        voxels + (static_cast<std::size_t>(y) * ascans + static_cast<std::size_t>(x)) * depth;
    const float c = fminf(fmaxf(z, 0.0f), static_cast<float>(depth - 1));
    const int z0 = static_cast<int>(floorf(c));
    const int z1 = z0 + 1 < depth ? z0 + 1 : z0;
    const float v0 = column[z0];
    const float v1 = column[z1];
    return (v0 + (v1 - v0) * (c - static_cast<float>(z0))) * (1.0f / 255.0f);
  }
};

// Jumps over bricks whose largest voxel is below `level` (u8): no sample there can contribute.
// The next sample taken is the first of the ray's regular positions past the brick, so the
// samples that remain are those the CPU reference takes.
struct BrickSkipper {
  const std::uint8_t* bricks;  // largest voxel per brick, [bz][by][bx] with x the A-scan axis
  int nx, ny, nz;
  float level;
  __host__ __device__ int next_sample(Vec3 v, Vec3 dir, float t0, float dt, int k) const {
    const int bx = min(max(static_cast<int>(floorf((v.x + 0.5f) / kBrick)), 0), nx - 1);
    const int by = min(max(static_cast<int>(floorf((v.y + 0.5f) / kBrick)), 0), ny - 1);
    const int bz = min(max(static_cast<int>(floorf((v.z + 0.5f) / kBrick)), 0), nz - 1);
    if (static_cast<float>(bricks[(bz * ny + by) * nx + bx]) >= level) return k;
    const float lo[3] = {bx * kBrick - 0.5f, by * kBrick - 0.5f, bz * kBrick - 0.5f};
    const float pos[3] = {v.x, v.y, v.z};
    const float d[3] = {dir.x, dir.y, dir.z};
    float exit = 1e30f;
    for (int i = 0; i < 3; ++i) {
      if (fabsf(d[i]) < 1e-12f) continue;
      const float bound = d[i] > 0.0f ? lo[i] + kBrick : lo[i];
      exit = fminf(exit, (bound - pos[i]) / d[i]);
    }
    const float t = t0 + (static_cast<float>(k) + 0.5f) * dt;
    const int next = static_cast<int>(ceilf((t + fmaxf(exit, 0.0f) - t0) / dt - 0.5f));
    return next > k ? next : k + 1;
  }
};

__global__ void volume_kernel(RenderParams p, TextureSampler sampler, BrickSkipper skipper,
                              bool skip, uchar4* out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  const int eye = blockIdx.z;
  if (x >= p.width || y >= p.height) return;
  const Rgba c = skip ? render_ray(p, sampler, skipper, x, y, eye)
                      : render_ray(p, sampler, NoSkip{}, x, y, eye);
  out[y * p.width * p.eyes + eye * p.width + x] =
      make_uchar4(to_u8(c.r), to_u8(c.g), to_u8(c.b), to_u8(c.a));
}

__global__ void plane_kernel(RenderParams p, TextureSampler sampler, uchar4* out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= p.width || y >= p.height) return;
  const Rgba c = render_plane(p, sampler, x, y);
  out[y * p.width + x] = make_uchar4(to_u8(c.r), to_u8(c.g), to_u8(c.b), to_u8(c.a));
}

// The LA-MIP composite's projections (la_mip.hpp). En face: a warp per A-scan column, the lanes
// striding its depth (coalesced bytes: at whole positions a sample is its voxel / 255, so the
// maximum is taken on the bytes), then a warp reduction that keeps the brightest and, among
// equals, the shallowest: la_mip_en_face_texel()'s result.
// Only B-scans [first, end), whose voxels changed.
constexpr int kEnFaceThreads = 256;
__global__ void la_mip_en_face_kernel(RenderParams p, const std::uint8_t* voxels, int first,
                                      int end, float* buffer) {
  const int column = first * p.dim_a + (blockIdx.x * blockDim.x + threadIdx.x) / 32;
  const int lane = threadIdx.x % 32;
  const int a = column % p.dim_a;
  const int b = column / p.dim_a;
  if (b >= end) return;  // whole warps: blockDim.x is a multiple of 32
  const std::uint8_t* voxel = voxels + static_cast<std::size_t>(column) * p.dim_d;
  int best = 0;
  int best_d = 0;
  for (int d = lane; d < p.dim_d; d += 32) {
    const int v = voxel[d];
    if (v > best) {  // d grows per lane: the first of equals stays
      best = v;
      best_d = d;
    }
  }
  // The brightest, and among equals the shallowest: the largest of (value, -depth) as one key.
  using WarpMax = cub::WarpReduce<unsigned long long>;
  __shared__ typename WarpMax::TempStorage storage[kEnFaceThreads / 32];
  const unsigned long long key = WarpMax(storage[threadIdx.x / 32])
                                     .Reduce((static_cast<unsigned long long>(best) << 32) |
                                                 (0xffffffffu - static_cast<unsigned>(best_d)),
                                             ::cuda::maximum<>{});
  if (lane == 0) {
    const LaMipBuffer l = la_mip_buffer(p);
    const std::size_t i = static_cast<std::size_t>(b) * l.a + static_cast<std::size_t>(a);
    buffer[l.en_face_max() + i] = static_cast<float>(key >> 32) * (1.0f / 255.0f);
    buffer[l.en_face_depth() + i] =
        static_cast<float>(0xffffffffu - static_cast<unsigned>(key & 0xffffffffu));
  }
}

// The projections are kept between renders and made again only where they changed: the rows
// (B-scans) whose voxels or RPE changed since they were made (`row_dirty`, from
// la_mip_dirty_rows_kernel). A group changes a few of 128 B-scans, so a render with a new group
// redoes a fraction of the work, with the same result as making them whole (maxima are exact).
//
// Which rows changed (kRowChanged): those of [first, end) (their voxels, known on the host),
// every row when `all`, and those whose RPE differs from `made_with` (the reference the
// projections were made with, which this kernel then brings up to date; these also get
// kRpeChanged). A block per row, which also zeroes the row's LA-MIP along the A-scans when it
// changed (la_mip_along_kernel adds its parts into it).
constexpr std::uint8_t kRowChanged = 1;
constexpr std::uint8_t kRpeChanged = 2;
__global__ void la_mip_dirty_rows_kernel(RenderParams p, float* made_with, int first, int end,
                                         bool all, std::uint8_t* row_dirty, float* buffer) {
  const int b = blockIdx.x;
  __shared__ int rpe_changed;
  if (threadIdx.x == 0) rpe_changed = all ? 1 : 0;
  __syncthreads();
  const std::size_t row = static_cast<std::size_t>(b) * p.dim_a;
  for (int a = threadIdx.x; a < p.dim_a; a += blockDim.x) {
    const float now = p.reference_px[row + a];
    if (__float_as_int(now) != __float_as_int(made_with[row + a])) {
      rpe_changed = 1;  // every writer writes 1
      made_with[row + a] = now;
    }
  }
  __syncthreads();
  const bool changed = rpe_changed != 0 || (b >= first && b < end);
  if (changed) {
    const LaMipBuffer l = la_mip_buffer(p);
    for (int z = threadIdx.x; z < p.dim_d; z += blockDim.x) {
      buffer[la_mip_texel(l, LaMipAxis::along_ascans, b, z)] = 0.0f;
    }
  }
  if (threadIdx.x != 0) return;
  row_dirty[b] =
      static_cast<std::uint8_t>((changed ? kRowChanged : 0) | (rpe_changed != 0 ? kRpeChanged : 0));
}

// The two LA-MIPs: neighbouring threads take neighbouring panel depths z of one lateral position,
// so they read neighbouring voxels of the same columns.
//
// Along the A-scans (a curve within one B-scan, its middle's RPE in the same row): only rows that
// changed; grid z splits each curve into parts of kLaMipPart samples, combined by atomicMax on the
// float's bits (order-preserving for the non-negative maxima) into texels zeroed first (by
// la_mip_dirty_rows_kernel).
constexpr int kLaMipPart = 32;

__device__ void max_into(float* target, float value) {
  atomicMax(reinterpret_cast<int*>(target), __float_as_int(value));
}

// grid: x panel depths, y B-scans, z parts of the curves.
__global__ void la_mip_along_kernel(RenderParams p, ColumnSampler sampler,
                                    const std::uint8_t* row_dirty, float* buffer) {
  const int z = blockIdx.x * blockDim.x + threadIdx.x;
  const int b = blockIdx.y;
  const int k0 = blockIdx.z * kLaMipPart;
  if (z >= p.dim_d || row_dirty[b] == 0) return;
  const int k1 = min(k0 + kLaMipPart, p.dim_a);
  const float best = la_mip_curve_max(p, sampler, LaMipAxis::along_ascans, b, z, k0, k1);
  max_into(buffer + la_mip_texel(la_mip_buffer(p), LaMipAxis::along_ascans, b, z), best);
}

// Across the B-scans (a curve through every B-scan at one A-scan): the maximum over each part of
// kLaMipAcrossPart B-scans is kept ([part][z][a]) and made again only when a row of the part
// changed, or every part when the RPE of a row the curves' middle reads changed (it sets their
// depth); then each texel is the maximum of its parts.
constexpr int kLaMipAcrossPart = 16;

IOCT_HD int la_mip_across_part_count(const RenderParams& p) {
  return (p.dim_b + kLaMipAcrossPart - 1) / kLaMipAcrossPart;
}

// grid: x panel depths, y A-scans, z parts.
__global__ void la_mip_across_part_kernel(RenderParams p, ColumnSampler sampler,
                                          const std::uint8_t* row_dirty, float* parts) {
  const int z = blockIdx.x * blockDim.x + threadIdx.x;
  const int a = blockIdx.y;
  const int part = blockIdx.z;
  if (z >= p.dim_d) return;
  const int k0 = part * kLaMipAcrossPart;
  const int k1 = min(k0 + kLaMipAcrossPart, p.dim_b);
  // The middle's RPE: reference_at(a, (dim_b - 1) / 2) reads these two rows.
  const float middle = 0.5f * static_cast<float>(p.dim_b - 1);
  const int m0 = static_cast<int>(floorf(middle));
  const int m1 = m0 + 1 < p.dim_b ? m0 + 1 : m0;
  bool dirty = ((row_dirty[m0] | row_dirty[m1]) & kRpeChanged) != 0;
  for (int k = k0; k < k1 && !dirty; ++k) dirty = row_dirty[k] != 0;
  if (!dirty) return;
  parts[(static_cast<std::size_t>(part) * p.dim_d + z) * p.dim_a + a] =
      la_mip_curve_max(p, sampler, LaMipAxis::across_bscans, a, z, k0, k1);
}

// grid: x A-scans, y panel depths.
__global__ void la_mip_across_join_kernel(RenderParams p, const float* parts, float* buffer) {
  const int a = blockIdx.x * blockDim.x + threadIdx.x;
  const int z = blockIdx.y;
  if (a >= p.dim_a) return;
  const std::size_t plane = static_cast<std::size_t>(p.dim_d) * p.dim_a;
  const float* texel = parts + static_cast<std::size_t>(z) * p.dim_a + a;
  float best = 0.0f;
  for (int part = 0; part < la_mip_across_part_count(p); ++part)
    best = fmaxf(best, texel[part * plane]);
  buffer[la_mip_texel(la_mip_buffer(p), LaMipAxis::across_bscans, a, z)] = best;
}

__global__ void la_mip_composite_kernel(RenderParams p, const float* buffer, uchar4* out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= p.width || y >= p.height) return;
  const Rgba c = la_mip_composite_pixel(p, buffer, x, y);
  out[y * p.width + x] = make_uchar4(to_u8(c.r), to_u8(c.g), to_u8(c.b), to_u8(c.a));
}

// The bricks' maxima in two passes, each with a thread per output, so that a group's update keeps
// the whole GPU busy (one thread per brick, reading its 12^3 voxels one by one, took 0.12 ms on an
// H100 for a group's 4 brick rows).
//
// Pass 1: for each column (B-scan b, A-scan a) of B-scans [b0, b1), the largest voxel of each
// brick's depth range with its apron. Neighbouring threads take neighbouring depth ranges of one
// column: their reads are a few bytes apart (coalesced).
__global__ void column_brick_kernel(const std::uint8_t* volume, int ascans, int depth, int nz,
                                    int b0, int b1, std::uint8_t* column_maxima) {
  const int bz = blockIdx.x * blockDim.x + threadIdx.x;
  const int a = blockIdx.y;
  const int b = b0 + static_cast<int>(blockIdx.z);
  if (bz >= nz || b >= b1) return;
  const std::size_t column = static_cast<std::size_t>(b) * ascans + a;
  const std::uint8_t* voxels = volume + column * depth;
  const int d0 = max(bz * kBrick - kBrickApron, 0),
            d1 = min(bz * kBrick + kBrick + kBrickApron, depth);
  unsigned hi = 0;
  for (int d = d0; d < d1; ++d) hi = max(hi, static_cast<unsigned>(voxels[d]));
  column_maxima[column * nz + bz] = static_cast<std::uint8_t>(hi);
}

// Pass 2: the largest voxel of each brick of brick rows [by0, by1) (B-scan direction), over its
// voxels and an apron of kBrickApron on every side: the largest of its columns' maxima.
__global__ void brick_kernel(const std::uint8_t* column_maxima, int ascans, int bscans, int nx,
                             int ny, int nz, int by0, int by1, std::uint8_t* bricks) {
  const int bz = blockIdx.x * blockDim.x + threadIdx.x;
  const int by = by0 + blockIdx.y;
  const int bx = blockIdx.z * blockDim.z + threadIdx.z;
  if (bx >= nx || by >= by1 || bz >= nz) return;
  const int a0 = max(bx * kBrick - kBrickApron, 0),
            a1 = min(bx * kBrick + kBrick + kBrickApron, ascans);
  const int b0 = max(by * kBrick - kBrickApron, 0),
            b1 = min(by * kBrick + kBrick + kBrickApron, bscans);
  unsigned hi = 0;
  for (int b = b0; b < b1; ++b) {
    for (int a = a0; a < a1; ++a) {
      hi = max(hi, static_cast<unsigned>(
                       column_maxima[(static_cast<std::size_t>(b) * ascans + a) * nz + bz]));
    }
  }
  bricks[(bz * ny + by) * nx + bx] = static_cast<std::uint8_t>(hi);
}

// Integer centre-of-mass sums per B-scan (exactly those of centre_of_mass_sums()). One warp per
// A-scan, its lanes reading the column's consecutive 4-byte words (coalesced; byte by byte where
// the depth is not a multiple of 4), reduced by a warp reduction.
constexpr int kCentreOfMassWarps = 8;
__device__ inline void add_to_centre_of_mass(unsigned v, int d, unsigned long long& weighted,
                                             unsigned long long& weight) {
  if (v < kCentreOfMassLevel) return;
  weighted += static_cast<unsigned long long>(v) * static_cast<unsigned>(d);
  weight += v;
}
__global__ void centre_of_mass_kernel(const std::uint8_t* volume, int ascans, int depth, int first,
                                      unsigned long long* sums) {
  const int lane = threadIdx.x % 32;
  const int a = blockIdx.x * kCentreOfMassWarps + threadIdx.x / 32;
  const int b = first + blockIdx.y;
  if (a >= ascans) return;  // a whole warp: the shuffles below see only full warps
  const std::uint8_t* column = volume + (static_cast<std::size_t>(b) * ascans + a) * depth;
  unsigned long long weighted = 0, weight = 0;
  if (depth % 4 == 0) {  // every column starts on a word (the volume's allocation is aligned)
    const auto* words = reinterpret_cast<const std::uint32_t*>(column);
    for (int w = lane; w < depth / 4; w += 32) {
      const std::uint32_t four = words[w];
      for (int k = 0; k < 4; ++k)
        add_to_centre_of_mass((four >> (8 * k)) & 0xffu, 4 * w + k, weighted, weight);
    }
  } else {
    for (int d = lane; d < depth; d += 32) add_to_centre_of_mass(column[d], d, weighted, weight);
  }
  using WarpSum = cub::WarpReduce<unsigned long long>;
  __shared__ typename WarpSum::TempStorage storage[kCentreOfMassWarps];
  WarpSum sum(storage[threadIdx.x / 32]);
  weighted = sum.Sum(weighted);
  __syncwarp();  // the temporary storage is used again
  weight = sum.Sum(weight);
  if (lane != 0) return;
  atomicAdd(&sums[2 * b], weighted);
  atomicAdd(&sums[2 * b + 1], weight);
}

}  // namespace

struct CudaRenderer::State {
  cudaStream_t stream = nullptr;
  cudaArray_t array = nullptr;
  cudaTextureObject_t texture = 0;
  VolumeDims dims;
  cuda::DeviceArray<std::uint8_t> linear;  // the volume once more, for bricks and sums
  cuda::DeviceArray<std::uint8_t> bricks;  // the largest voxel of each brick
  // Per column, the largest voxel of each brick's depth range (the bricks' first pass).
  cuda::DeviceArray<std::uint8_t> column_maxima;
  int nx = 0, ny = 0, nz = 0;
  cuda::DeviceArray<unsigned long long>
      sums;  // centre of mass: (weighted depth, weight) per B-scan
  DeviceLayerReference layers;
  cuda::DeviceArray<float> uploaded_ilm, uploaded_rpe;  // host surfaces, on their way to `layers`
  bool has_volume = false;
  // Tables, re-made when their part of the config changes.
  cuda::DeviceArray<float> transfer_lut, lab_lut;
  std::vector<float> host_transfer_lut;
  bool tables_valid = false;
  TransferFunctions table_transfer;
  LabColorMap table_colors;
  bool table_colorize = true;
  cuda::DeviceArray<uchar4> image;
  std::uint32_t width = 0, height = 0;
  // The frame's way to the host: a pinned block (a copy to pageable memory is synchronous and
  // several times slower: it cannot overlap the host's work). One in flight is always of the
  // last render: a render drops an untaken one.
  cuda::PinnedDownload frame_download;
  // The LA-MIP composite's projections (la_mip.hpp's buffer), kept between renders: made again
  // only for the B-scans whose voxels changed since (the host knows which: [first, end)) or whose
  // RPE changed (found on the device against the reference they were made with).
  cuda::DeviceArray<float> la_mip;
  cuda::DeviceArray<float> la_mip_parts;      // [part][z][a], see la_mip_across_part_kernel
  cuda::DeviceArray<float> la_mip_made_with;  // the RPE the projections were made with
  cuda::DeviceArray<std::uint8_t> la_mip_row_dirty;
  bool la_mip_whole = true;                        // none made yet for this volume: make them whole
  bool la_mip_layers_new = false;                  // the layer reference was made again since
  std::uint32_t la_mip_first = 0, la_mip_end = 0;  // B-scans whose voxels changed since
  bool owns_stream = true;
  cuda::Event volume_ready;  // a device volume's stream, when it is not ours

  void free_volume() {
    if (texture != 0) cudaDestroyTextureObject(texture);
    if (array != nullptr) cudaFreeArray(array);
    texture = 0;
    array = nullptr;
  }

  void allocate(VolumeDims d) {
    if (d.bscans == 0 || d.ascans == 0 || d.depth == 0) {
      throw std::invalid_argument("cannot render an empty volume");
    }
    free_volume();
    dims = d;
    const cudaChannelFormatDesc format = cudaCreateChannelDesc<unsigned char>();
    IOCT_CUDA_CHECK(
        cudaMalloc3DArray(&array, &format, make_cudaExtent(d.depth, d.ascans, d.bscans)));
    cudaResourceDesc resource{};
    resource.resType = cudaResourceTypeArray;
    resource.res.array.array = array;
    cudaTextureDesc tex{};
    tex.addressMode[0] = tex.addressMode[1] = tex.addressMode[2] = cudaAddressModeClamp;
    tex.filterMode = cudaFilterModeLinear;
    tex.readMode = cudaReadModeNormalizedFloat;
    tex.normalizedCoords = 0;
    IOCT_CUDA_CHECK(cudaCreateTextureObject(&texture, &resource, &tex, nullptr));
    linear.resize(std::size_t{d.bscans} * d.ascans * d.depth);
    nx = static_cast<int>((d.ascans + kBrick - 1) / kBrick);
    ny = static_cast<int>((d.bscans + kBrick - 1) / kBrick);
    nz = static_cast<int>((d.depth + kBrick - 1) / kBrick);
    bricks.resize(std::size_t(nx) * ny * nz);
    column_maxima.resize(std::size_t{d.bscans} * d.ascans * nz);
    sums.resize(std::size_t{d.bscans} * 2);
    IOCT_CUDA_CHECK(
        cudaMemsetAsync(sums.data(), 0, sums.size() * sizeof(unsigned long long), stream));
    layers.resize(d.bscans, d.ascans);
    la_mip_whole = true;
    has_volume = true;
  }

  // Copies B-scans [first, first + count) of `pixels` (host memory, or device memory ordered on
  // this stream) and refreshes what depends on them. From the host they cross the bus once, into
  // the linear copy; the texture's array is filled from there. The layer reference is made on the
  // device, from `device_surfaces` where they are, or from `surfaces` uploaded: with a device
  // volume and device surfaces an update is enqueued only, with no round trip to the host.
  void upload(const std::uint8_t* pixels, bool on_device, std::uint32_t first, std::uint32_t count,
              const segmentation::Surfaces* surfaces,
              const segmentation::DeviceSurfaceView* device_surfaces) {
    upload_volume(pixels, on_device, first, count);
    make_layers(surfaces, device_surfaces);
    // A host volume may be pinned (then its copy is truly asynchronous): the caller may change it
    // once this returns.
    if (!on_device) IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
  }

  // The volume's part of upload(): the B-scans, the bricks and the centre-of-mass sums.
  void upload_volume(const std::uint8_t* pixels, bool on_device, std::uint32_t first,
                     std::uint32_t count) {
    const std::size_t bscan_bytes = std::size_t{dims.ascans} * dims.depth;
    std::uint8_t* changed = linear.data() + first * bscan_bytes;
    if (on_device) {
      IOCT_CUDA_CHECK(cudaMemcpyAsync(changed, pixels + first * bscan_bytes, count * bscan_bytes,
                                      cudaMemcpyDeviceToDevice, stream));
    } else {
      cuda::copy_async(changed, pixels + first * bscan_bytes, count * bscan_bytes,
                       cudaMemcpyHostToDevice, stream, cuda::Payload::volume,
                       "copy of the B-scans to the renderer");
    }
    cudaMemcpy3DParms copy{};
    copy.srcPtr = make_cudaPitchedPtr(changed, dims.depth, dims.depth, dims.ascans);
    copy.dstArray = array;
    copy.dstPos = make_cudaPos(0, 0, first);
    copy.extent = make_cudaExtent(dims.depth, dims.ascans, count);
    copy.kind = cudaMemcpyDeviceToDevice;
    IOCT_CUDA_CHECK(cudaMemcpy3DAsync(&copy, stream));
    la_mip_first = la_mip_first < la_mip_end ? std::min(la_mip_first, first) : first;
    la_mip_end = std::max(la_mip_end, first + count);
    // Bricks whose voxels or apron reach into the changed B-scans, from the columns they read.
    const int by0 = std::max(0, (static_cast<int>(first) - kBrickApron) / kBrick);
    const int by1 =
        std::min(ny, (static_cast<int>(first + count) + kBrickApron + kBrick - 1) / kBrick);
    const int b0 = std::max(by0 * kBrick - kBrickApron, 0);
    const int b1 = std::min(by1 * kBrick + kBrickApron, static_cast<int>(dims.bscans));
    const int column_threads = std::min(256, (nz + 31) / 32 * 32);
    column_brick_kernel<<<dim3((nz + column_threads - 1) / column_threads, dims.ascans, b1 - b0),
                          column_threads, 0, stream>>>(linear.data(), dims.ascans, dims.depth, nz,
                                                       b0, b1, column_maxima.data());
    IOCT_CUDA_CHECK(cudaGetLastError());
    const dim3 block(32, 1, 4);
    const dim3 grid((nz + 31) / 32, by1 - by0, (nx + 3) / 4);
    brick_kernel<<<grid, block, 0, stream>>>(column_maxima.data(), dims.ascans, dims.bscans, nx, ny,
                                             nz, by0, by1, bricks.data());
    IOCT_CUDA_CHECK(cudaGetLastError());
    IOCT_CUDA_CHECK(cudaMemsetAsync(sums.data() + 2 * first, 0,
                                    2 * count * sizeof(unsigned long long), stream));
    centre_of_mass_kernel<<<dim3((dims.ascans + kCentreOfMassWarps - 1) / kCentreOfMassWarps,
                                 count),
                            32 * kCentreOfMassWarps, 0, stream>>>(linear.data(), dims.ascans,
                                                                  dims.depth, first, sums.data());
    IOCT_CUDA_CHECK(cudaGetLastError());
  }

  // The layers' part of upload(): the layer reference from the surfaces (device ones where given,
  // or host ones uploaded) and the centre-of-mass sums.
  void make_layers(const segmentation::Surfaces* surfaces,
                   const segmentation::DeviceSurfaceView* device_surfaces) {
    const std::size_t n = std::size_t{dims.bscans} * dims.ascans;
    const float* ilm = nullptr;
    const float* rpe = nullptr;
    if (device_surfaces != nullptr) {
      if (device_surfaces->bscans == dims.bscans && device_surfaces->ascans == dims.ascans) {
        ilm = device_surfaces->ilm;
        rpe = device_surfaces->rpe;
      }
    } else if (surfaces != nullptr && surfaces->bscans == dims.bscans &&
               surfaces->ascans == dims.ascans && surfaces->rpe.size() == n &&
               surfaces->ilm.size() == n) {
      uploaded_ilm.resize(n);
      uploaded_rpe.resize(n);
      cuda::copy_async(uploaded_ilm.data(), surfaces->ilm.data(), n * sizeof(float),
                       cudaMemcpyHostToDevice, stream, cuda::Payload::other,
                       "copy of the ILM to the renderer");
      cuda::copy_async(uploaded_rpe.data(), surfaces->rpe.data(), n * sizeof(float),
                       cudaMemcpyHostToDevice, stream, cuda::Payload::other,
                       "copy of the RPE to the renderer");
      ilm = uploaded_ilm.data();
      rpe = uploaded_rpe.data();
    }
    layers.make(sums.data(), dims.depth, ilm, rpe, stream);
    la_mip_layers_new = true;
  }

  // Brings the LA-MIP projections up to date with the volume and the layer reference (`p`: the
  // render's parameters, reference_px the RPE).
  void update_la_mip(const RenderParams& p) {
    const bool changed = la_mip_whole || la_mip_layers_new || la_mip_first < la_mip_end;
    if (!changed) return;
    const LaMipBuffer l = la_mip_buffer(p);
    if (la_mip_whole) {
      la_mip.resize(l.size());
      la_mip_parts.resize(std::size_t(la_mip_across_part_count(p)) * l.d * l.a);
      la_mip_made_with.resize(l.a * l.b);
      la_mip_row_dirty.resize(l.b);
      la_mip_first = 0;
      la_mip_end = dims.bscans;
    }
    la_mip_dirty_rows_kernel<<<static_cast<unsigned>(l.b), 128, 0, stream>>>(
        p, la_mip_made_with.data(), static_cast<int>(la_mip_first), static_cast<int>(la_mip_end),
        la_mip_whole, la_mip_row_dirty.data(), la_mip.data());
    IOCT_CUDA_CHECK(cudaGetLastError());
    if (la_mip_first < la_mip_end) {
      const std::size_t columns = std::size_t{la_mip_end - la_mip_first} * l.a;
      la_mip_en_face_kernel<<<static_cast<unsigned>((columns * 32 + kEnFaceThreads - 1) /
                                                    kEnFaceThreads),
                              kEnFaceThreads, 0, stream>>>(
          p, linear.data(), static_cast<int>(la_mip_first), static_cast<int>(la_mip_end),
          la_mip.data());
      IOCT_CUDA_CHECK(cudaGetLastError());
    }
    const int threads = 128;
    const unsigned z_blocks = static_cast<unsigned>((p.dim_d + threads - 1) / threads);
    const ColumnSampler sampler{linear.data(), static_cast<int>(dims.ascans),
                                static_cast<int>(dims.depth)};
    la_mip_along_kernel<<<dim3(z_blocks, static_cast<unsigned>(p.dim_b),
                               static_cast<unsigned>((p.dim_a + kLaMipPart - 1) / kLaMipPart)),
                          threads, 0, stream>>>(p, sampler, la_mip_row_dirty.data(), la_mip.data());
    la_mip_across_part_kernel<<<dim3(z_blocks, static_cast<unsigned>(p.dim_a),
                                     static_cast<unsigned>(la_mip_across_part_count(p))),
                                threads, 0, stream>>>(p, sampler, la_mip_row_dirty.data(),
                                                      la_mip_parts.data());
    la_mip_across_join_kernel<<<dim3(static_cast<unsigned>((p.dim_a + 127) / 128),
                                     static_cast<unsigned>(p.dim_d)),
                                128, 0, stream>>>(p, la_mip_parts.data(), la_mip.data());
    IOCT_CUDA_CHECK(cudaGetLastError());
    la_mip_whole = false;
    la_mip_layers_new = false;
    la_mip_first = la_mip_end = 0;
  }

  void prepare_tables(const RenderConfig& config) {
    const bool colorize = config.mode != RenderMode::layer_aware || config.layer_aware.colorize;
    if (tables_valid && table_transfer == config.enhanced.transfer &&
        table_colors == config.layer_aware.colors && table_colorize == colorize) {
      return;
    }
    const RenderTables tables = bake_tables(config);
    transfer_lut.resize(tables.transfer_lut.size());
    lab_lut.resize(tables.lab_lut.size());
    IOCT_CUDA_CHECK(cudaMemcpyAsync(transfer_lut.data(), tables.transfer_lut.data(),
                                    tables.transfer_lut.size() * sizeof(float),
                                    cudaMemcpyHostToDevice, stream));
    IOCT_CUDA_CHECK(cudaMemcpyAsync(lab_lut.data(), tables.lab_lut.data(),
                                    tables.lab_lut.size() * sizeof(float), cudaMemcpyHostToDevice,
                                    stream));
    IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
    host_transfer_lut = tables.transfer_lut;
    table_transfer = config.enhanced.transfer;
    table_colors = config.layer_aware.colors;
    table_colorize = colorize;
    tables_valid = true;
  }

  // u8 level below which a brick's samples cannot contribute in this mode.
  float empty_level(const RenderConfig& config) const {
    if (config.mode == RenderMode::layer_aware) {
      return static_cast<float>(config.layer_aware.i_min * 255.0) - 1e-3f;
    }
    // The transfer function's opacity is 0 up to the table entry before its first non-zero one.
    float level = 0.0f;
    for (int i = 0; i < kTransferLutSize; ++i) {
      if (host_transfer_lut[4 * i + 3] > 0.0f) {
        level = static_cast<float>(std::max(0, i - 1)) * 255.0f / (kTransferLutSize - 1);
        break;
      }
    }
    if (config.enhanced.use_threshold) {
      level = std::max(level, static_cast<float>(config.enhanced.threshold * 255.0) - 1e-3f);
    }
    return level;
  }
};

CudaRenderer::CudaRenderer() : state_(std::make_unique<State>()) {
  IOCT_CUDA_CHECK(cudaStreamCreateWithFlags(&state_->stream, cudaStreamNonBlocking));
}

CudaRenderer::~CudaRenderer() {
  if (state_->stream != nullptr) cudaStreamSynchronize(state_->stream);
  state_->free_volume();
  if (state_->stream != nullptr && state_->owns_stream) cudaStreamDestroy(state_->stream);
}

void CudaRenderer::use_stream(void* stream) {
  State& s = *state_;
  IOCT_CUDA_CHECK(cudaStreamSynchronize(s.stream));
  if (s.owns_stream) IOCT_CUDA_CHECK(cudaStreamDestroy(s.stream));
  s.stream = static_cast<cudaStream_t>(stream);
  s.owns_stream = false;
}

void CudaRenderer::update_bscans(VolumeRef volume, std::uint32_t first, std::uint32_t count,
                                 const segmentation::Surfaces* surfaces) {
  if (!volume.is_device()) {
    update_bscans(volume.host(), first, count, surfaces);
    return;
  }
  update_device(volume, first, count, surfaces, nullptr);
}

void CudaRenderer::update_bscans(VolumeRef volume, std::uint32_t first, std::uint32_t count,
                                 const segmentation::DeviceSurfaceView& surfaces) {
  update_device(volume, first, count, nullptr, &surfaces);
}

void CudaRenderer::update_device(VolumeRef volume, std::uint32_t first, std::uint32_t count,
                                 const segmentation::Surfaces* surfaces,
                                 const segmentation::DeviceSurfaceView* device_surfaces) {
  const BscanRun run = prepare_update(volume, first, count);
  state_->upload(volume.device(), true, run.first, run.count, surfaces, device_surfaces);
}

CudaRenderer::BscanRun CudaRenderer::prepare_update(VolumeRef volume, std::uint32_t first,
                                                    std::uint32_t count) {
  State& s = *state_;
  const VolumeDims& d = volume.dims();
  if (volume.stream() != s.stream) {
    IOCT_CUDA_CHECK(cudaEventRecord(s.volume_ready.get(), volume.stream()));
    IOCT_CUDA_CHECK(cudaStreamWaitEvent(s.stream, s.volume_ready.get(), 0));
  }
  if (!s.has_volume || !(s.dims == d)) {
    IOCT_CUDA_CHECK(cudaStreamSynchronize(s.stream));  // nothing may still read the old texture
    s.allocate(d);
    return {0, d.bscans};
  }
  check_bscan_range(d.bscans, first, count);
  return {first, count};
}

void CudaRenderer::update_volume(VolumeRef volume, std::uint32_t first, std::uint32_t count) {
  if (!volume.is_device()) throw std::logic_error("update_volume() takes a device volume");
  const BscanRun run = prepare_update(volume, first, count);
  state_->upload_volume(volume.device(), true, run.first, run.count);
}

void CudaRenderer::update_layers(const segmentation::DeviceSurfaceView& surfaces) {
  if (!state_->has_volume) throw std::logic_error("update_layers() before update_volume()");
  state_->make_layers(nullptr, &surfaces);
}

void CudaRenderer::set_volume(const Volume& volume, const segmentation::Surfaces* surfaces) {
  state_->allocate(VolumeDims::of(volume));
  state_->upload(volume.pixels().data(), false, 0, volume.bscans(), surfaces, nullptr);
}

void CudaRenderer::update_bscans(const Volume& volume, std::uint32_t first, std::uint32_t count,
                                 const segmentation::Surfaces* surfaces) {
  const VolumeDims& d = state_->dims;
  if (!state_->has_volume || volume.bscans() != d.bscans || volume.ascans() != d.ascans ||
      volume.depth() != d.depth) {
    set_volume(volume, surfaces);
    return;
  }
  check_bscan_range(volume.bscans(), first, count);
  state_->upload(volume.pixels().data(), false, first, count, surfaces, nullptr);
}

void CudaRenderer::render_on_device(const RenderConfig& config) {
  State& s = *state_;
  if (!s.has_volume) throw std::logic_error("render() before set_volume()");
  // A frame's copy started and never taken (its caller threw) is the last frame's: dropped, so
  // that download_frame() never hands it out as this one.
  if (s.frame_download.in_flight()) s.frame_download.wait();
  RenderParams p = bake_params(config, s.dims, 0.0f);
  s.prepare_tables(config);
  p.transfer_lut = s.transfer_lut.data();
  p.lab_lut = s.lab_lut.data();
  p.reference_px =
      config.mode == RenderMode::axial_colorization ? s.layers.axial_plane_px() : s.layers.rpe_px();
  if (config.layer_aware.colors.d_rpe_px <= 0.0) p.measured_d_rpe_px = s.layers.mean_thickness_px();
  s.width = output_width(p);
  s.height = static_cast<std::uint32_t>(p.height);
  s.image.resize(std::size_t{s.width} * s.height);
  const TextureSampler sampler{s.texture};
  const dim3 block(16, 8);
  const dim3 grid((p.width + block.x - 1) / block.x, (p.height + block.y - 1) / block.y, p.eyes);
  if (is_volume_mode(config.mode)) {
    const BrickSkipper skipper{s.bricks.data(), s.nx, s.ny, s.nz, s.empty_level(config)};
    volume_kernel<<<grid, block, 0, s.stream>>>(p, sampler, skipper, skipper.level > 0.0f,
                                                s.image.data());
  } else if (config.mode == RenderMode::la_mip_composite) {
    s.update_la_mip(p);
    la_mip_composite_kernel<<<grid, block, 0, s.stream>>>(p, s.la_mip.data(), s.image.data());
  } else {
    plane_kernel<<<grid, block, 0, s.stream>>>(p, sampler, s.image.data());
  }
  IOCT_CUDA_CHECK(cudaGetLastError());
}

void CudaRenderer::start_frame_download() {
  State& s = *state_;
  if (s.width == 0) throw std::logic_error("start_frame_download() before render_on_device()");
  s.frame_download.add(s.image.data(), std::size_t{s.width} * s.height * sizeof(uchar4));
  s.frame_download.enqueue(s.stream, cuda::Payload::other, "copy of the frame to the host");
}

void CudaRenderer::download_frame(RgbaImage& image) {
  State& s = *state_;
  if (!s.frame_download.in_flight()) start_frame_download();
  s.frame_download.wait();
  image.width = s.width;
  image.height = s.height;
  s.frame_download.take(0, image.rgba);  // no fill: a frame of the same size keeps its storage
}

void CudaRenderer::render(const RenderConfig& config, RgbaImage& image) {
  render_on_device(config);
  download_frame(image);
}

LayerReference CudaRenderer::layer_reference() const {
  return state_->layers.download(state_->stream);
}

void CudaRenderer::synchronize() {
  IOCT_CUDA_CHECK(cudaStreamSynchronize(state_->stream));
}
void* CudaRenderer::stream() const noexcept {
  return state_->stream;
}

}  // namespace ioct::gpu::render
