// The CUDA renderer (builds with CUDA only): the volume in a 3D texture (trilinear filtering in
// hardware), a min-max brick grid (8^3 voxels) for empty-space skipping, updated for the bricks a
// group's B-scans touch, and one launch for both eyes of a stereo pair. Pixels are computed by the
// same pixel_shader.hpp as the CPU reference.
#pragma once

#include <cstdint>
#include <memory>

#include "ioct/gpu/render/renderer.hpp"

namespace ioct::gpu::render {

class CudaRenderer final : public Renderer {
 public:
  // Throws std::runtime_error naming the CUDA call that failed.
  CudaRenderer();
  ~CudaRenderer() override;
  CudaRenderer(const CudaRenderer&) = delete;
  CudaRenderer& operator=(const CudaRenderer&) = delete;

  void set_volume(const Volume& volume, const segmentation::Surfaces* surfaces) override;
  void update_bscans(const Volume& volume, std::uint32_t first, std::uint32_t count,
                     const segmentation::Surfaces* surfaces) override;
  void render(const RenderConfig& config, RgbaImage& image) override;
  std::string_view backend_name() const noexcept override { return "cuda"; }

  // The live CUDA pipeline's volume is already on the device: B-scans [first, first + count) of
  // `device_pixels` (u8 [bscan][ascan][depth] of `bscans` x `ascans` x `depth`) are new. A new
  // geometry reallocates and takes the whole volume.
  void update_from_device(const std::uint8_t* device_pixels, std::uint32_t bscans,
                          std::uint32_t ascans, std::uint32_t depth, std::uint32_t first,
                          std::uint32_t count, const segmentation::Surfaces* surfaces);

  // Renders into device memory only and returns at once (stream-ordered): for display from the
  // device and for timing. image_on_device() is valid after synchronize().
  void render_on_device(const RenderConfig& config);
  const std::uint8_t* image_on_device() const noexcept;
  std::uint32_t image_width() const noexcept;
  std::uint32_t image_height() const noexcept;
  void synchronize();
  // The stream the renderer works on (a cudaStream_t).
  void* stream() const noexcept;

  // Share of samples skipped by the brick grid in the last render_on_device() is not measured;
  // this counts the empty bricks of the current volume for the given emptiness level (u8).
  std::uint64_t empty_bricks(float level);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace ioct::gpu::render
