#include "frame_instrument.hpp"

#include <limits>

#include "ioct/gpu/render/image_projection.hpp"

namespace ioct::gpu::live {

shm::FrameInstrument frame_instrument(const instruments::InstrumentFindings* findings,
                                      double warn_rpe_um, const render::RenderParams* render) {
  constexpr float kUnknown = std::numeric_limits<float>::quiet_NaN();
  shm::FrameInstrument out{};
  out.to_ilm_um = kUnknown;
  out.to_rpe_um = kUnknown;
  for (int eye = 0; eye < 2; ++eye) out.render_x[eye] = out.render_y[eye] = kUnknown;
  out.warn_rpe_um = static_cast<float>(warn_rpe_um);
  if (findings == nullptr) return out;  // off
  out.instruments = static_cast<std::uint32_t>(findings->tips.size());
  const instruments::InstrumentTip* tip = findings->nearest_tip();
  if (tip == nullptr) {
    out.state = static_cast<std::uint32_t>(shm::FrameInstrumentState::none);
    return out;
  }
  out.state = static_cast<std::uint32_t>(shm::FrameInstrumentState::found);
  switch (tip->source) {
    case instruments::DistanceSource::measured:
      out.distance_source = static_cast<std::uint32_t>(shm::FrameDistanceSource::measured);
      break;
    case instruments::DistanceSource::inferred:
      out.distance_source = static_cast<std::uint32_t>(shm::FrameDistanceSource::inferred);
      break;
    case instruments::DistanceSource::none:
      out.distance_source = static_cast<std::uint32_t>(shm::FrameDistanceSource::none);
      break;
  }
  out.warning = findings->warning ? 1 : 0;
  out.translucent = tip->translucent ? 1 : 0;
  out.tip_voxel[0] = static_cast<float>(tip->bscan);
  out.tip_voxel[1] = static_cast<float>(tip->ascan);
  out.tip_voxel[2] = static_cast<float>(tip->depth_px);
  out.tip_um[0] = static_cast<float>(tip->x_um);
  out.tip_um[1] = static_cast<float>(tip->y_um);
  out.tip_um[2] = static_cast<float>(tip->z_um);
  out.to_ilm_um = static_cast<float>(tip->to_ilm_um);  // NaN stays NaN
  out.to_rpe_um = static_cast<float>(tip->to_rpe_um);
  if (render != nullptr) {
    const render::Vec3 voxel{static_cast<float>(tip->ascan), static_cast<float>(tip->bscan),
                             static_cast<float>(tip->depth_px)};
    for (int eye = 0; eye < 2; ++eye) {
      if (const auto at = render::project_voxel(*render, voxel, eye)) {
        out.render_x[eye] = at->x;
        out.render_y[eye] = at->y;
      }
    }
  }
  return out;
}

}  // namespace ioct::gpu::live
