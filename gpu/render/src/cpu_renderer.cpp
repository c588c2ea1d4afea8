#include "ioct/gpu/render/cpu_renderer.hpp"

#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <thread>

#include "ioct/gpu/render/frame_setup.hpp"
#include "ioct/gpu/render/la_mip.hpp"
#include "ioct/gpu/render/pixel_shader.hpp"

namespace ioct::gpu::render {

namespace {

// Runs work(i) for i in [0, count) on `threads` threads, in order of i per thread.
template <class Work>
void parallel_for(std::uint32_t count, unsigned threads, const Work& work) {
  std::atomic<std::uint32_t> next{0};
  const auto run = [&] {
    for (std::uint32_t i = next++; i < count; i = next++) work(i);
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < std::min<unsigned>(threads, count); ++t) pool.emplace_back(run);
  run();
  for (auto& t : pool) t.join();
}

CentreOfMassSums total(const std::vector<CentreOfMassSums>& per_bscan) {
  CentreOfMassSums sum;
  for (const auto& s : per_bscan) {
    sum.weighted_depth += s.weighted_depth;
    sum.weight += s.weight;
  }
  return sum;
}

}  // namespace

CpuRenderer::CpuRenderer(unsigned threads)
    : threads_(threads == 0 ? std::max(1u, std::thread::hardware_concurrency()) : threads) {}

void CpuRenderer::set_volume(const Volume& volume, const segmentation::Surfaces* surfaces) {
  if (volume.bscans() == 0 || volume.ascans() == 0 || volume.depth() == 0) {
    throw std::invalid_argument("cannot render an empty volume");
  }
  volume_ = volume;
  sums_per_bscan_.assign(volume.bscans(), {});
  for (std::uint32_t b = 0; b < volume.bscans(); ++b) {
    sums_per_bscan_[b] = centre_of_mass_sums(volume, b, 1);
  }
  reference_ = make_layer_reference(volume.bscans(), volume.ascans(), volume.depth(), surfaces,
                                    total(sums_per_bscan_));
  has_volume_ = true;
}

void CpuRenderer::update_bscans(const Volume& volume, std::uint32_t first, std::uint32_t count,
                                const segmentation::Surfaces* surfaces) {
  if (!has_volume_ || !volume.same_shape(volume_)) {
    set_volume(volume, surfaces);
    return;
  }
  check_bscan_range(volume.bscans(), first, count);
  for (std::uint32_t b = first; b < first + count; ++b) {
    const auto src = volume.bscan(b);
    std::copy(src.begin(), src.end(), volume_.bscan(b).begin());
    sums_per_bscan_[b] = centre_of_mass_sums(volume, b, 1);
  }
  reference_ = make_layer_reference(volume.bscans(), volume.ascans(), volume.depth(), surfaces,
                                    total(sums_per_bscan_));
}

void CpuRenderer::render(const RenderConfig& config, RgbaImage& image) {
  if (!has_volume_) throw std::logic_error("render() before set_volume()");
  const VolumeDims dims{volume_.bscans(), volume_.ascans(), volume_.depth()};
  RenderParams params = bake_params(config, dims, reference_.mean_thickness_px);
  const RenderTables tables = bake_tables(config);
  params.transfer_lut = tables.transfer_lut.data();
  params.lab_lut = tables.lab_lut.data();
  params.reference_px = config.mode == RenderMode::axial_colorization
                            ? reference_.axial_plane_px.data()
                            : reference_.rpe_px.data();
  const CpuSampler sampler{volume_.pixels().data(), static_cast<int>(dims.ascans),
                           static_cast<int>(dims.bscans), static_cast<int>(dims.depth)};
  const std::uint32_t width = output_width(params);
  const std::uint32_t height = static_cast<std::uint32_t>(params.height);
  image.resize(width, height);
  const bool volume_mode = is_volume_mode(config.mode);
  const bool la_mip = config.mode == RenderMode::la_mip_composite;
  const unsigned threads = config.cpu_threads == 0 ? threads_ : config.cpu_threads;

  std::vector<float> projections;
  if (la_mip) {
    const LaMipBuffer layout = la_mip_buffer(params);
    projections.assign(layout.size(), 0.0f);
    float* buffer = projections.data();
    parallel_for(dims.bscans, threads, [&](std::uint32_t b) {
      for (int a = 0; a < params.dim_a; ++a) {
        la_mip_en_face_texel(params, sampler, a, static_cast<int>(b), buffer);
      }
    });
    parallel_for(dims.depth, threads, [&](std::uint32_t z) {
      const int zi = static_cast<int>(z);
      for (const LaMipAxis axis : {LaMipAxis::across_bscans, LaMipAxis::along_ascans}) {
        const int positions = la_mip_positions(params, axis);
        const int length = la_mip_curve_length(params, axis);
        for (int at = 0; at < positions; ++at) {
          buffer[la_mip_texel(layout, axis, at, zi)] =
              la_mip_curve_max(params, sampler, axis, at, zi, 0, length);
        }
      }
    });
  }

  parallel_for(height, threads, [&](std::uint32_t y) {
    for (std::uint32_t x = 0; x < width; ++x) {
      const int eye = static_cast<int>(x) / params.width;
      const int ex = static_cast<int>(x) % params.width;
      const int row = static_cast<int>(y);
      const Rgba c = volume_mode ? render_ray(params, sampler, NoSkip{}, ex, row, eye)
                     : la_mip    ? la_mip_composite_pixel(params, projections.data(), ex, row)
                                 : render_plane(params, sampler, ex, row);
      std::uint8_t* out = image.rgba.data() + (std::size_t{y} * width + x) * 4;
      out[0] = to_u8(c.r);
      out[1] = to_u8(c.g);
      out[2] = to_u8(c.b);
      out[3] = to_u8(c.a);
    }
  });
}

RgbaImage render_volume(const Volume& volume, const segmentation::Surfaces* surfaces,
                        const RenderConfig& config) {
  CpuRenderer renderer(config.cpu_threads);
  renderer.set_volume(volume, surfaces);
  RgbaImage image;
  renderer.render(config, image);
  return image;
}

}  // namespace ioct::gpu::render
