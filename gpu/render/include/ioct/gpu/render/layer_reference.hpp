// The reference layers the colour maps and LA-MIP measure depth against, derived once per volume
// state: the RPE with its holes filled (every A-scan needs a value), the mean retinal thickness
// (d_rpe of Weiss et al.) and the axial centre of mass (the plane of the axial colorization).
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/gpu/segmentation/surfaces.hpp"
#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu::render {

// Voxels at or above this u8 level count towards the axial centre of mass, weighted by value.
inline constexpr std::uint8_t kCentreOfMassLevel = 64;

struct LayerReference {
  std::uint32_t bscans = 0, ascans = 0;
  std::vector<float> rpe_px;       // [bscan][ascan], no NaN; the axial plane without an RPE
  float mean_thickness_px = 0.0f;  // mean rpe - ilm over A-scans having both; 0: unknown
  // [bscan][ascan], all the axial centre of mass: a surface like the RPE, so that the pixel code
  // reads either through the same pointer.
  std::vector<float> axial_plane_px;
};

// Integer sums of value x depth and of value over the voxels >= kCentreOfMassLevel of B-scans
// [first, first + count): what both renderers accumulate (exactly) for the centre of mass.
struct CentreOfMassSums {
  std::uint64_t weighted_depth = 0;
  std::uint64_t weight = 0;
};
CentreOfMassSums centre_of_mass_sums(const Volume& volume, std::uint32_t first,
                                     std::uint32_t count);

// `surfaces` may be null or of other dimensions than the volume (then ignored). NaN A-scans of
// the RPE take the linear interpolation of the nearest measured ones along their B-scan; B-scans
// with none take the nearest B-scan's row; without any RPE the centre-of-mass plane stands in.
LayerReference make_layer_reference(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth,
                                    const segmentation::Surfaces* surfaces, CentreOfMassSums sums);

}  // namespace ioct::gpu::render
