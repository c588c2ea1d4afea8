// The CUDA renderer (builds with CUDA only): the volume in a 3D texture (trilinear filtering in
// hardware), a grid of brick maxima (8^3 voxels) for empty-space skipping, updated for the bricks a
// group's B-scans touch, and one launch for both eyes of a stereo pair. Pixels are computed by the
// same pixel_shader.hpp as the CPU reference.
#pragma once

#include <cstdint>
#include <memory>

#include "ioct/gpu/render/layer_reference.hpp"
#include "ioct/gpu/render/renderer.hpp"

namespace ioct::gpu::segmentation {
struct DeviceSurfaceView;
}

namespace ioct::gpu::render {

class CudaRenderer final : public Renderer {
 public:
  // Throws std::runtime_error naming the CUDA call that failed.
  CudaRenderer();
  ~CudaRenderer() override;
  CudaRenderer(const CudaRenderer&) = delete;
  CudaRenderer& operator=(const CudaRenderer&) = delete;

  void set_volume(const Volume& volume, const segmentation::Surfaces* surfaces) override;
  using Renderer::update_bscans;
  void update_bscans(const Volume& volume, std::uint32_t first, std::uint32_t count,
                     const segmentation::Surfaces* surfaces) override;
  // Device refs are waited for (their stream) and copied device to device.
  void update_bscans(VolumeRef volume, std::uint32_t first, std::uint32_t count,
                     const segmentation::Surfaces* surfaces) override;
  // The live chain: a device volume with the segmenter's device surfaces. Enqueued only: the
  // layer reference is made on the device too, so nothing comes to the host.
  void update_bscans(VolumeRef volume, std::uint32_t first, std::uint32_t count,
                     const segmentation::DeviceSurfaceView& surfaces);
  // The same update in its two parts, so that the first can run while the surfaces are being
  // made: the B-scans of a device volume into the texture, the bricks and the centre-of-mass
  // sums (waiting for the volume's stream), then the layer reference from the device surfaces
  // (the caller orders them before the renderer's stream). A render needs both.
  void update_volume(VolumeRef volume, std::uint32_t first, std::uint32_t count);
  void update_layers(const segmentation::DeviceSurfaceView& surfaces);
  void render(const RenderConfig& config, RgbaImage& image) override;
  std::string_view backend_name() const noexcept override { return "cuda"; }

  // Renders into device memory only and returns at once (stream-ordered): for timing.
  void render_on_device(const RenderConfig& config);
  // The last render_on_device()'s frame to the host: start_frame_download() enqueues its copy
  // (into a pinned block, so it runs while the host works), download_frame() waits for it
  // (starting it first if it was not) and puts it into `image`; a render in between drops it.
  // render() is render_on_device() and download_frame() in a row; a caller with host work of its
  // own does it in between.
  void start_frame_download();
  void download_frame(RgbaImage& image);
  void synchronize();
  // The layer reference of the last update, brought to the host (tests: the CPU reference's
  // make_layer_reference() on the same surfaces gives the same).
  LayerReference layer_reference() const;
  // The stream the renderer works on (a cudaStream_t).
  void* stream() const noexcept;
  // Works on the caller's `stream` (a cudaStream_t that outlives the renderer) from now on, so
  // that its work queues behind the caller's without events.
  void use_stream(void* stream);

 private:
  void update_device(VolumeRef volume, std::uint32_t first, std::uint32_t count,
                     const segmentation::Surfaces* surfaces,
                     const segmentation::DeviceSurfaceView* device_surfaces);
  // Orders the renderer's stream after the volume's, and allocates anew for other dimensions.
  // Returns the B-scans to upload: [first, first + count), or all of them after an allocation.
  struct BscanRun {
    std::uint32_t first = 0, count = 0;
  };
  BscanRun prepare_update(VolumeRef volume, std::uint32_t first, std::uint32_t count);

  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace ioct::gpu::render
