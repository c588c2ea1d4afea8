#include "ioct/gpu/filters/cpu_volume_filter.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "ioct/gpu/filters/median_networks.hpp"

namespace ioct::gpu::filters {

// A run of 32 voxels along depth processed as one value: every compare-exchange of the
// forgetful selection becomes a loop the compiler turns into one SIMD min and one SIMD max.
struct DepthRun {
  static constexpr std::uint32_t kLength = 32;
  std::uint8_t v[kLength];
};

inline DepthRun lane_min(const DepthRun& a, const DepthRun& b) {
  DepthRun r;
  for (std::uint32_t i = 0; i < DepthRun::kLength; ++i) r.v[i] = a.v[i] < b.v[i] ? a.v[i] : b.v[i];
  return r;
}
inline DepthRun lane_max(const DepthRun& a, const DepthRun& b) {
  DepthRun r;
  for (std::uint32_t i = 0; i < DepthRun::kLength; ++i) r.v[i] = a.v[i] < b.v[i] ? b.v[i] : a.v[i];
  return r;
}

namespace {

std::uint32_t clamped(std::int64_t index, std::uint32_t size) {
  return static_cast<std::uint32_t>(std::clamp<std::int64_t>(index, 0, std::int64_t{size} - 1));
}

// The 9 rows (B-scan x A-scan neighbours, clamped) around output (bscan, ascan).
void neighbour_rows(const Volume& in, std::uint32_t bscan, std::uint32_t ascan,
                    const std::uint8_t* (&rows)[9]) {
  const std::uint8_t* base = in.pixels().data();
  int k = 0;
  for (int dz = -1; dz <= 1; ++dz) {
    const std::uint32_t z = clamped(std::int64_t{bscan} + dz, in.bscans());
    for (int da = -1; da <= 1; ++da) {
      const std::uint32_t a = clamped(std::int64_t{ascan} + da, in.ascans());
      rows[k++] = base + (std::size_t{z} * in.ascans() + a) * in.depth();
    }
  }
}

// The runs of depth [d0, d0 + 32) of each row shifted by -1, 0 and +1 voxel, three per row in
// `v`. Interior runs read straight from the rows; runs touching either end clamp each index.
template <std::size_t Rows>
void load_depth_runs(const std::uint8_t* const (&rows)[Rows], std::uint32_t d0, std::uint32_t depth,
                     DepthRun (&v)[3 * Rows]) {
  constexpr std::uint32_t kRun = DepthRun::kLength;
  const bool interior = d0 >= 1 && d0 + kRun + 1 <= depth;
  for (std::size_t k = 0; k < Rows; ++k) {
    for (int dd = -1; dd <= 1; ++dd) {
      DepthRun& run = v[3 * k + static_cast<std::size_t>(dd + 1)];
      if (interior) {
        std::memcpy(run.v, rows[k] + d0 + dd, kRun);
      } else {
        for (std::uint32_t i = 0; i < kRun; ++i) {
          run.v[i] = rows[k][clamped(std::int64_t{d0} + i + dd, depth)];
        }
      }
    }
  }
}

}  // namespace

void median3x3x3_bscan(const Volume& in, std::uint32_t bscan, std::span<std::uint8_t> out) {
  const std::uint32_t depth = in.depth();
  if (bscan >= in.bscans() || out.size() != in.bscan_pixels()) {
    throw std::invalid_argument("median3x3x3_bscan: B-scan or output size out of range");
  }
  constexpr std::uint32_t kRun = DepthRun::kLength;
  for (std::uint32_t a = 0; a < in.ascans(); ++a) {
    const std::uint8_t* rows[9];
    neighbour_rows(in, bscan, a, rows);
    std::uint8_t* out_row = out.data() + std::size_t{a} * depth;
    for (std::uint32_t d0 = 0; d0 < depth; d0 += kRun) {
      DepthRun v[27];
      load_depth_runs(rows, d0, depth, v);
      const DepthRun median = median27_forgetful(v);
      std::memcpy(out_row + d0, median.v, std::min(kRun, depth - d0));
    }
  }
}

void median3x3_bscan(const Volume& in, std::uint32_t bscan, std::span<std::uint8_t> out) {
  const std::uint32_t depth = in.depth();
  if (bscan >= in.bscans() || out.size() != in.bscan_pixels()) {
    throw std::invalid_argument("median3x3_bscan: B-scan or output size out of range");
  }
  constexpr std::uint32_t kRun = DepthRun::kLength;
  const std::uint8_t* plane = in.bscan(bscan).data();
  for (std::uint32_t a = 0; a < in.ascans(); ++a) {
    const std::uint8_t* rows[3];
    for (int da = -1; da <= 1; ++da) {
      rows[da + 1] = plane + std::size_t{clamped(std::int64_t{a} + da, in.ascans())} * depth;
    }
    std::uint8_t* out_row = out.data() + std::size_t{a} * depth;
    for (std::uint32_t d0 = 0; d0 < depth; d0 += kRun) {
      DepthRun v[9];
      load_depth_runs(rows, d0, depth, v);
      sort9(v);
      std::memcpy(out_row + d0, v[4].v, std::min(kRun, depth - d0));
    }
  }
}

void gaussian5x5_bscan(std::span<const std::uint8_t> in, std::uint32_t ascans, std::uint32_t depth,
                       const GaussianTaps& taps, std::span<std::uint8_t> out,
                       std::vector<std::uint32_t>& rows) {
  const std::size_t pixels = std::size_t{ascans} * depth;
  if (in.size() != pixels || out.size() != pixels) {
    throw std::invalid_argument("gaussian5x5_bscan: B-scan sizes do not match");
  }
  rows.resize(pixels);
  const std::uint32_t t0 = taps.taps[0], t1 = taps.taps[1], t2 = taps.taps[2];
  // Along depth (contiguous): the interior without index clamping, so it vectorises.
  for (std::uint32_t a = 0; a < ascans; ++a) {
    const std::uint8_t* src = in.data() + std::size_t{a} * depth;
    std::uint32_t* dst = rows.data() + std::size_t{a} * depth;
    const auto at = [&](std::int64_t d) { return std::uint32_t{src[clamped(d, depth)]}; };
    const auto edge = [&](std::uint32_t d) {
      dst[d] = t0 * (at(std::int64_t{d} - 2) + at(std::int64_t{d} + 2)) +
               t1 * (at(std::int64_t{d} - 1) + at(std::int64_t{d} + 1)) + t2 * at(d);
    };
    if (depth < 5) {
      for (std::uint32_t d = 0; d < depth; ++d) edge(d);
      continue;
    }
    edge(0);
    edge(1);
    for (std::uint32_t d = 2; d + 2 < depth; ++d) {
      dst[d] = t0 * (std::uint32_t{src[d - 2]} + src[d + 2]) +
               t1 * (std::uint32_t{src[d - 1]} + src[d + 1]) + t2 * src[d];
    }
    edge(depth - 2);
    edge(depth - 1);
  }
  // Across A-scans, rounding half up to u8.
  constexpr std::uint32_t kHalf = 1u << (GaussianTaps::kShift - 1);
  for (std::uint32_t a = 0; a < ascans; ++a) {
    const auto row = [&](std::int64_t offset) {
      return rows.data() + std::size_t{clamped(std::int64_t{a} + offset, ascans)} * depth;
    };
    const std::uint32_t* m2 = row(-2);
    const std::uint32_t* m1 = row(-1);
    const std::uint32_t* c = row(0);
    const std::uint32_t* p1 = row(1);
    const std::uint32_t* p2 = row(2);
    std::uint8_t* dst = out.data() + std::size_t{a} * depth;
    for (std::uint32_t d = 0; d < depth; ++d) {
      const std::uint32_t sum = t0 * (m2[d] + p2[d]) + t1 * (m1[d] + p1[d]) + t2 * c[d] + kHalf;
      dst[d] = static_cast<std::uint8_t>(sum >> GaussianTaps::kShift);
    }
  }
}

CpuVolumeFilter::CpuVolumeFilter(const VolumeFilterConfig& config, unsigned threads)
    : config_((config.validate(), config)),
      taps_(make_gaussian_taps(config.gaussian_sigma)),
      pool_(threads),
      workspaces_(pool_.threads()) {}

void CpuVolumeFilter::filter_volume(const Volume& in, Volume& out) {
  if (&in == &out) throw std::invalid_argument("volume filter: input and output are one volume");
  out.reshape(in.bscans(), in.ascans(), in.depth());
  if (in.bscans() == 0) return;
  filter_bscans(in, out, {0, in.bscans()});
}

BscanRange CpuVolumeFilter::filter_group(const Volume& in, Volume& out, std::uint32_t first_bscan,
                                         std::uint32_t count) {
  const BscanRange outputs = check_group_request(in, out, first_bscan, count);
  filter_bscans(in, out, outputs);
  return outputs;
}

void CpuVolumeFilter::filter_bscans(const Volume& in, Volume& out, BscanRange outputs) {
  if (in.ascans() == 0 || in.depth() == 0) return;
  pool_.run(outputs.count, [&](std::uint32_t index, unsigned worker) {
    filter_bscan(in, out, outputs.first + index, workspaces_[worker]);
  });
}

void CpuVolumeFilter::filter_bscan(const Volume& in, Volume& out, std::uint32_t bscan,
                                   Workspace& workspace) const {
  std::span<std::uint8_t> target = out.bscan(bscan);
  const auto median = [&](std::span<std::uint8_t> to) {
    if (config_.median_window == MedianWindow::bscan_3x3) {
      median3x3_bscan(in, bscan, to);
    } else {
      median3x3x3_bscan(in, bscan, to);
    }
  };
  if (config_.median && config_.gaussian) {
    workspace.median.resize(in.bscan_pixels());
    median(workspace.median);
    gaussian5x5_bscan(workspace.median, in.ascans(), in.depth(), taps_, target, workspace.rows);
  } else if (config_.median) {
    median(target);
  } else if (config_.gaussian) {
    gaussian5x5_bscan(in.bscan(bscan), in.ascans(), in.depth(), taps_, target, workspace.rows);
  } else {
    std::ranges::copy(in.bscan(bscan), target.begin());
  }
}

}  // namespace ioct::gpu::filters
