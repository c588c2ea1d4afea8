// A volume of u8 pixels [bscan][ascan][depth], depth contiguous: the layout every later stage
// (filters, segmentation, rendering) reads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace ioct::gpu {

class Volume {
 public:
  Volume() = default;
  Volume(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth) {
    reshape(bscans, ascans, depth);
  }

  // New dimensions; the pixels are unspecified until written (the memory is reused).
  void reshape(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth) {
    bscans_ = bscans;
    ascans_ = ascans;
    depth_ = depth;
    pixels_.resize(std::size_t{bscans} * ascans * depth);
  }

  std::uint32_t bscans() const noexcept { return bscans_; }
  std::uint32_t ascans() const noexcept { return ascans_; }
  std::uint32_t depth() const noexcept { return depth_; }
  std::size_t bscan_pixels() const noexcept { return std::size_t{ascans_} * depth_; }
  bool same_shape(const Volume& other) const noexcept {
    return bscans_ == other.bscans_ && ascans_ == other.ascans_ && depth_ == other.depth_;
  }

  std::span<std::uint8_t> bscan(std::uint32_t b) noexcept {
    return {pixels_.data() + b * bscan_pixels(), bscan_pixels()};
  }
  std::span<const std::uint8_t> bscan(std::uint32_t b) const noexcept {
    return {pixels_.data() + b * bscan_pixels(), bscan_pixels()};
  }
  std::uint8_t at(std::uint32_t b, std::uint32_t a, std::uint32_t d) const noexcept {
    return pixels_[(std::size_t{b} * ascans_ + a) * depth_ + d];
  }
  std::span<const std::uint8_t> pixels() const noexcept { return pixels_; }
  std::span<std::uint8_t> pixels() noexcept { return pixels_; }

 private:
  std::uint32_t bscans_ = 0;
  std::uint32_t ascans_ = 0;
  std::uint32_t depth_ = 0;
  std::vector<std::uint8_t> pixels_;
};

}  // namespace ioct::gpu
