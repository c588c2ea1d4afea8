// Rendering of a volume state: one interface with a CPU reference and a CUDA implementation that
// take the same RenderConfig and give the same image (within docs/rendering.md's tolerance).
//
// The live process calls set_volume() (or update_bscans() for the B-scans of a new group) once
// per volume state, then render() as often as it likes, at any view, without reprocessing:
//
//   auto renderer = make_renderer(Backend::automatic);
//   renderer->set_volume(volume, &surfaces);
//   renderer->render(config, image);           // RGBA, stereo pairs side by side
#pragma once

#include <cstdint>
#include <memory>
#include <string_view>

#include "ioct/gpu/cuda/backend.hpp"  // Backend, BackendUnavailable
#include "ioct/gpu/render/render_config.hpp"
#include "ioct/gpu/render/rgba_image.hpp"
#include "ioct/gpu/segmentation/surfaces.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"

namespace ioct::gpu::render {

class Renderer {
 public:
  virtual ~Renderer() = default;

  // A new volume state: keeps (a copy of) the volume and what the modes derive from it and from
  // `surfaces` (null, or of other dimensions: no RPE; the colour maps then measure depth against
  // the axial centre of mass). Throws std::invalid_argument for an empty volume.
  virtual void set_volume(const Volume& volume, const segmentation::Surfaces* surfaces) = 0;

  // The live case: only B-scans [first, first + count) of `volume` changed since set_volume()
  // with a volume of the same dimensions (otherwise this is set_volume()). The surfaces are
  // taken whole. Throws std::out_of_range for B-scans outside the volume.
  virtual void update_bscans(const Volume& volume, std::uint32_t first, std::uint32_t count,
                             const segmentation::Surfaces* surfaces) = 0;

  // update_bscans on a ref: a host ref as above. A device ref (the CUDA renderer) is read where it
  // is, after the work enqueued on its stream, with no copy of the volume to the host; a ref of
  // other dimensions than the last is a new volume (all its B-scans are taken). Throws
  // std::invalid_argument for a device ref on a backend without device memory.
  virtual void update_bscans(VolumeRef volume, std::uint32_t first, std::uint32_t count,
                             const segmentation::Surfaces* surfaces);

  // Renders the current state into `image` (resized to output_width x eyes by output_height).
  // Throws ConfigError for a bad config, std::logic_error before any set_volume().
  virtual void render(const RenderConfig& config, RgbaImage& image) = 0;

  virtual std::string_view backend_name() const noexcept = 0;
};

// Throws BackendUnavailable for cuda when this build or machine has none. automatic: cuda when
// usable, else cpu. cpu_threads 0: the hardware's.
std::unique_ptr<Renderer> make_renderer(Backend backend, unsigned cpu_threads = 0);

// For the implementations of update_bscans(): throws std::out_of_range naming B-scans
// [first, first + count) when they are empty or not inside a volume of `bscans`.
void check_bscan_range(std::uint32_t bscans, std::uint32_t first, std::uint32_t count);

// One call on the CPU reference: set_volume() then render().
RgbaImage render_volume(const Volume& volume, const segmentation::Surfaces* surfaces,
                        const RenderConfig& config);

}  // namespace ioct::gpu::render
