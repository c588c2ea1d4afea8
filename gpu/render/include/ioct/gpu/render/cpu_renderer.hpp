// The CPU reference renderer: plain loops over the pixels (rows shared between threads), each
// pixel computed by pixel_shader.hpp with a trilinear sampler written out in full. No skipping:
// every sample along a ray is taken until the ray's early termination.
#pragma once

#include <math.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "ioct/gpu/render/layer_reference.hpp"
#include "ioct/gpu/render/renderer.hpp"

namespace ioct::gpu::render {

// Trilinear interpolation of u8 voxels as intensities in [0, 1], edges clamped. Coordinates in
// voxels: x along the A-scans, y across B-scans, z depth; voxel centres at integers.
struct CpuSampler {
  const std::uint8_t* voxels = nullptr;
  int ascans = 0, bscans = 0, depth = 0;

  float operator()(float x, float y, float z) const {
    const auto axis = [](float c, int n, int& i0, int& i1, float& f) {
      const float cc = fminf(fmaxf(c, 0.0f), static_cast<float>(n - 1));
      i0 = static_cast<int>(floorf(cc));
      i1 = i0 + 1 < n ? i0 + 1 : i0;
      f = cc - static_cast<float>(i0);
    };
    int x0, x1, y0, y1, z0, z1;
    float fx, fy, fz;
    axis(x, ascans, x0, x1, fx);
    axis(y, bscans, y0, y1, fy);
    axis(z, depth, z0, z1, fz);
    const auto v = [&](int a, int b, int d) {
      return static_cast<float>(voxels[(static_cast<std::size_t>(b) * ascans + a) * depth + d]);
    };
    const float c00 = v(x0, y0, z0) + (v(x0, y0, z1) - v(x0, y0, z0)) * fz;
    const float c01 = v(x1, y0, z0) + (v(x1, y0, z1) - v(x1, y0, z0)) * fz;
    const float c10 = v(x0, y1, z0) + (v(x0, y1, z1) - v(x0, y1, z0)) * fz;
    const float c11 = v(x1, y1, z0) + (v(x1, y1, z1) - v(x1, y1, z0)) * fz;
    const float c0 = c00 + (c01 - c00) * fx;
    const float c1 = c10 + (c11 - c10) * fx;
    return (c0 + (c1 - c0) * fy) * (1.0f / 255.0f);
  }
};

class CpuRenderer final : public Renderer {
 public:
  explicit CpuRenderer(unsigned threads = 0);

  void set_volume(const Volume& volume, const segmentation::Surfaces* surfaces) override;
  using Renderer::update_bscans;
  void update_bscans(const Volume& volume, std::uint32_t first, std::uint32_t count,
                     const segmentation::Surfaces* surfaces) override;
  void render(const RenderConfig& config, RgbaImage& image) override;
  std::string_view backend_name() const noexcept override { return "cpu"; }

  const LayerReference& reference() const noexcept { return reference_; }

 private:
  unsigned threads_;
  Volume volume_;
  bool has_volume_ = false;
  std::vector<CentreOfMassSums> sums_per_bscan_;
  LayerReference reference_;
};

}  // namespace ioct::gpu::render
