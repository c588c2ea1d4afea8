// A JPEG the live stages wrote (a frame's render, B-scan or tip pair), decoded for a test to look
// at: RGB, or grey for a grey JPEG; empty (and a test failure) when it does not decode.
#pragma once

#include <gtest/gtest.h>

#include <turbojpeg.h>

#include <cstddef>
#include <cstdlib>
#include <span>
#include <vector>

namespace ioct::gpu::live {

struct DecodedJpeg {
  int width = 0, height = 0;
  std::vector<unsigned char> pixels;  // row-major, 3 bytes a px (RGB) or 1 (grey)
};

inline DecodedJpeg decode_jpeg(std::span<const std::byte> jpeg) {
  DecodedJpeg out;
  tjhandle handle = tjInitDecompress();
  int subsampling = 0, colorspace = 0;
  const auto* data = reinterpret_cast<const unsigned char*>(jpeg.data());
  const unsigned long size = jpeg.size();
  if (tjDecompressHeader3(handle, data, size, &out.width, &out.height, &subsampling, &colorspace) ==
      0) {
    const int format = colorspace == TJCS_GRAY ? TJPF_GRAY : TJPF_RGB;
    out.pixels.resize(static_cast<std::size_t>(out.width) * out.height * tjPixelSize[format]);
    if (tjDecompress2(handle, data, size, out.pixels.data(), out.width, 0, out.height, format, 0) !=
        0) {
      ADD_FAILURE() << "decoding failed: " << tjGetErrorStr2(handle);
      out = {};
    }
  } else {
    ADD_FAILURE() << "not a JPEG: " << tjGetErrorStr2(handle);
  }
  tjDestroy(handle);
  return out;
}

// Mean absolute difference per byte of two pictures of one size (-1 where they differ in size
// or are empty).
inline double mean_abs_difference(std::span<const unsigned char> a,
                                  std::span<const unsigned char> b) {
  if (a.size() != b.size() || a.empty()) return -1.0;
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += std::abs(int{a[i]} - int{b[i]});
  return sum / static_cast<double>(a.size());
}

}  // namespace ioct::gpu::live
