// The volume filters as one interface with a CPU and a CUDA implementation: median 3x3x3, then
// Gaussian 5x5 in each B-scan, on u8 volumes [bscan][ascan][depth].
//
// Borders replicate the edge pixel (clamp): a neighbour outside the volume reads the nearest
// pixel inside it, in every direction. For the median's radius of 1 this equals mirroring at the
// edge (scipy's 'reflect' and 'nearest' modes). Both implementations give the same bits.
#pragma once

#include <cstdint>
#include <memory>
#include <string_view>

#include "ioct/gpu/cuda/backend.hpp"  // Backend, BackendUnavailable
#include "ioct/gpu/filters/bscan_range.hpp"
#include "ioct/gpu/filters/filter_config.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"

namespace ioct::gpu::filters {

class VolumeFilter {
 public:
  virtual ~VolumeFilter() = default;

  // Filters every B-scan of `in` into `out`, which is reshaped to in's dimensions. `in` and
  // `out` must be different volumes (std::invalid_argument).
  virtual void filter_volume(const Volume& in, Volume& out) = 0;

  // The live case: input B-scans `changed` (a new group) were written into `in`. Recomputes the
  // output B-scans that depend on them, outputs_affected_by(changed), and returns that range;
  // every other B-scan of `out` is left alone. `out` must already have in's dimensions (from
  // filter_volume or an earlier volume). After every group is filtered this way, `out` equals
  // filter_volume(in). Throws std::invalid_argument for mismatched volumes and std::out_of_range
  // for a range outside the volume.
  virtual BscanRange filter_group(const Volume& in, Volume& out, std::uint32_t first_bscan,
                                  std::uint32_t count) = 0;

  // filter_group on refs: host refs as above (returns when `out` holds the result). Device refs
  // (the CUDA filter) are filtered where they are: enqueued on in's stream, nothing copied to the
  // host and nothing synchronised; `out` is another device volume of in's dimensions. Throws
  // std::invalid_argument for a host and a device ref together, or device refs on a backend that
  // has no device memory.
  virtual BscanRange filter_group(VolumeRef in, MutableVolumeRef out, BscanRange changed);

  virtual const VolumeFilterConfig& config() const noexcept = 0;
  virtual std::string_view backend_name() const noexcept = 0;
};

// Throws ConfigError for a bad config and BackendUnavailable when the backend is not in this
// build or (cuda) no usable device is present, with the reason.
std::unique_ptr<VolumeFilter> make_volume_filter(Backend backend, const VolumeFilterConfig& config,
                                                 unsigned cpu_threads = 1);

// Checks shared by the implementations: throws std::invalid_argument when `in` and `out` are the
// same object or `out` has other dimensions; std::out_of_range for a bad range. Returns the
// output range to recompute.
BscanRange check_group_request(const Volume& in, const Volume& out, std::uint32_t first_bscan,
                               std::uint32_t count);

}  // namespace ioct::gpu::filters
