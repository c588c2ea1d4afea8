#include "ioct/gpu/offline/layer_csv.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace ioct::gpu::offline {
namespace {

std::size_t line_count(const HeidelbergVol& vol) {
  std::size_t lines = 0;
  for (const VolBscan& b : vol.bscans) lines = std::max(lines, b.layers.size());
  return lines;
}

void append_number(std::string& row, double value) {
  row += ',';
  if (std::isnan(value)) return;
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, value);
  row.append(text, result.ptr);
}

}  // namespace

std::string layer_csv_header(const HeidelbergVol& vol) {
  const std::size_t lines = line_count(vol);
  std::string header = "bscan,ascan";
  for (std::size_t l = 0; l < lines; ++l) header += "," + layer_name(l) + "_px";
  for (std::size_t l = 0; l < lines; ++l) header += "," + layer_name(l) + "_um";
  return header;
}

void write_layer_csv(std::FILE* stream, const HeidelbergVol& vol) {
  const std::size_t lines = line_count(vol);
  const double um_per_px = vol.header.depth_spacing_mm * 1000.0;
  std::string text = layer_csv_header(vol) + "\n";
  for (std::size_t b = 0; b < vol.bscans.size(); ++b) {
    const VolBscan& bscan = vol.bscans[b];
    for (std::uint32_t a = 0; a < vol.header.ascans; ++a) {
      std::string row = std::to_string(b) + "," + std::to_string(a);
      const auto px = [&](std::size_t l) {
        return l < bscan.layers.size() ? double{bscan.layers[l][a]} : std::nan("");
      };
      for (std::size_t l = 0; l < lines; ++l) append_number(row, px(l));
      // float -> double first, so px * spacing is computed once, in double
      for (std::size_t l = 0; l < lines; ++l) append_number(row, px(l) * um_per_px);
      text += row + "\n";
    }
  }
  if (std::fwrite(text.data(), 1, text.size(), stream) != text.size()) {
    throw std::runtime_error(std::string("writing the layer CSV failed: ") + std::strerror(errno));
  }
}

}  // namespace ioct::gpu::offline
