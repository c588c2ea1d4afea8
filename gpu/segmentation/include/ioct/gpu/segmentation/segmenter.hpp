// Real-time segmentation of the ILM and the RPE, one interface with a CPU reference and a CUDA
// implementation that give the same surfaces (see docs/segmentation.md for the method).
//
// For each B-scan of a new group, on the filtered volume (u8 [bscan][ascan][depth]):
//   1. coarse search: the RPE on cells of 4 px over the whole depth, by dynamic programming along
//      the B-scan (bounded step between neighbouring A-scans, a cost per px of step: the shortest
//      path through the B-scan's A-scans, computed from both ends and joined in the middle);
//   2. prior from the neighbouring B-scans: per A-scan the median of the coarse RPE of this
//      B-scan and its two neighbours (their latest result) places the bands of the fine search;
//   3. fine search of the ILM (a rise from the dark vitreous) in the band above the coarse RPE,
//      then of the RPE (a bright band with no brighter one just beneath) in the band below the
//      ILM, both to the px with the same dynamic programming;
//   4. per A-scan: sub-px ILM, RPE centre and Bruch's membrane side, and a confidence from its
//      evidence against the B-scan's typical contrast; a B-scan with too little retinal evidence
//      is marked no_retina and its surfaces NaN;
// and for every B-scan the group's results reach:
//   5. measured A-scans smoothed over their 3 x 3 neighbourhood (across B-scans too); A-scans of
//      low confidence (an instrument's shadow) bridged from the nearest measured A-scans along the
//      B-scan and across B-scans, weighted by inverse lateral distance, or, where an earlier
//      volume measured them, carried from it, moved by the retina's axial motion since;
//   6. per B-scan, Bruch's membrane beneath RPE lifted off it (drusen): the floor of the BM
//      along the B-scan where the band's outer side rises above it (lifted_rpe.hpp).
//
// A segmenter keeps the intermediate results of the volume it last worked on (the neighbours'
// coarse RPE, the unsmoothed fits, the measured fits of earlier cycles), so groups of a live
// volume go in one after the other.
#pragma once

#include <cstdint>
#include <memory>
#include <string_view>

#include "ioct/gpu/cuda/backend.hpp"  // Backend, BackendUnavailable
#include "ioct/gpu/segmentation/segmentation_config.hpp"
#include "ioct/gpu/segmentation/surfaces.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"

namespace ioct::gpu::segmentation {

// B-scans [first, first + count).
struct BscanSpan {
  std::uint32_t first = 0;
  std::uint32_t count = 0;
  std::uint32_t end() const noexcept { return first + count; }
  friend bool operator==(const BscanSpan&, const BscanSpan&) = default;
};

class Segmenter {
 public:
  virtual ~Segmenter() = default;

  // The live case: B-scans `group` of `volume` are new. Segments them and rewrites in `surfaces`
  // every B-scan whose result depends on them (outputs_affected(), returned). `surfaces` of
  // other dimensions than the volume's (a new volume geometry, or a fresh Surfaces) is reset
  // first, and so is the segmenter's memory of the volume.
  // Throws std::invalid_argument for a volume whose dimensions the search cannot handle
  // (fewer than kMinDepth or more than kMaxDepth px deep, no A-scans or more than kMaxAscans, a
  // band larger than kMaxBand for this sampling), std::out_of_range for a group outside it.
  virtual BscanSpan segment_group(const Volume& volume, BscanSpan group, Surfaces& surfaces) = 0;

  // segment_group on a ref: a host ref as above, into `surfaces` (required). A device ref (the
  // CUDA segmenter) is segmented where it is, enqueued on its stream with no host copy and no
  // synchronisation; its surfaces stay on the device (CudaSegmenter::device_surfaces(),
  // download_surfaces()) and `surfaces` is not touched (may be null). A device ref of other
  // dimensions than the last starts a new volume. Throws std::invalid_argument for a missing
  // `surfaces` or a device ref on a backend without device memory, else as segment_group.
  virtual BscanSpan segment_group(VolumeRef volume, BscanSpan group, Surfaces* surfaces);

  // Every B-scan of `volume`, from nothing: forgets earlier volumes first. A volume of no B-scans
  // gives empty surfaces.
  void segment_volume(const Volume& volume, Surfaces& surfaces);

  // Forgets the volume worked on (the next group starts from nothing).
  virtual void forget() = 0;

  virtual const SegmentationConfig& config() const noexcept = 0;
  virtual const VolumeSampling& sampling() const noexcept = 0;
  virtual std::string_view backend_name() const noexcept = 0;

  // The output B-scans a new group changes: the group's own and those within bridge_bscans (at
  // least 1, the smoothing) on either side.
  BscanSpan outputs_affected(BscanSpan group, std::uint32_t bscans) const;
};

// Throws ConfigError for a bad config or sampling, BackendUnavailable when the backend is not in
// this build or (cuda) no usable device is present, with the reason. automatic: cuda when usable.
std::unique_ptr<Segmenter> make_segmenter(Backend backend, const SegmentationConfig& config,
                                          const VolumeSampling& sampling, unsigned cpu_threads = 1);

// Checks shared by the implementations: throws std::invalid_argument naming the dimensions when
// the volume cannot be segmented (see segment_group) and std::out_of_range for a group that is
// empty or reaches past the volume.
void check_group_request(const Volume& volume, BscanSpan group);
void check_group_request(VolumeDims volume, BscanSpan group);

}  // namespace ioct::gpu::segmentation
