// Volumes whose rendering can be worked out by hand (a sphere, flat slabs, one curved layer) and
// a synthetic layered retina with an instrument, for the CUDA-vs-CPU comparison and the benchmark.
#pragma once

#include <cstdint>

#include "ioct/gpu/segmentation/surfaces.hpp"
#include "ioct/gpu/volume/volume.hpp"

namespace ioct::render_test {

// A cube of n^3 voxels holding a sphere at its centre: value 255 up to radius - ramp/2, 0 beyond
// radius + ramp/2, linear in between (so the iso-surface of value 127.5 has the given radius and
// the gradient is radial everywhere on the ramp).
gpu::Volume make_sphere(std::uint32_t n, double radius, double ramp);

// `lateral` x `lateral` A-scans of `depth` px; depth px [begin, end) of every A-scan hold the
// slab's value, the rest 0.
struct Slab {
  std::uint32_t begin, end;
  std::uint8_t value;
};
gpu::Volume make_slabs(std::uint32_t lateral, std::uint32_t depth, const Slab* slabs,
                       std::size_t count);

// RPE depth of the curved-layer volume at an A-scan: a bowl plus a tilt, px.
double curved_layer_depth(std::uint32_t bscan, std::uint32_t ascan, std::uint32_t bscans,
                          std::uint32_t ascans, std::uint32_t depth);

struct VolumeWithSurfaces {
  gpu::Volume volume;
  gpu::segmentation::Surfaces surfaces;
};

// A dim background (value 30) with one bright layer centred at curved_layer_depth(): 250 within
// 1 px of it (so every A-scan has a voxel at the peak), falling off as a Gaussian of sigma 1 px;
// the surfaces give it as the RPE (and an ILM 20 px above it).
VolumeWithSurfaces make_curved_layer(std::uint32_t bscans, std::uint32_t ascans,
                                     std::uint32_t depth);

// A layered retina (nerve fibre layer, inner and outer layers, RPE, choroid) on a curved bowl
// with a foveal pit, speckle-like noise from a fixed seed, and a needle above the surface
// casting its shadow; the surfaces are its ILM and RPE.
VolumeWithSurfaces make_synthetic_retina(std::uint32_t bscans, std::uint32_t ascans,
                                         std::uint32_t depth, std::uint32_t seed = 1);

}  // namespace ioct::render_test
