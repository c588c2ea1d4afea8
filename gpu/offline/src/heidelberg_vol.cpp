#include "ioct/gpu/offline/heidelberg_vol.hpp"

#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>

#include "ioct/gpu/offline/input_file_error.hpp"

namespace ioct::gpu::offline {
namespace {

constexpr std::size_t kFileHeaderBytes = 2048;
constexpr std::size_t kBscanFixedBytes = 256;  // B-scan header fields before the lines
constexpr float kNoValue = 3.0e38f;            // stored values above this mean "none"

std::uint32_t le_u32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 |
         std::uint32_t{p[3]} << 24;
}
std::uint64_t le_u64(const std::uint8_t* p) {
  return std::uint64_t{le_u32(p)} | std::uint64_t{le_u32(p + 4)} << 32;
}
double le_f64(const std::uint8_t* p) {
  return std::bit_cast<double>(le_u64(p));
}
float le_f32(const std::uint8_t* p) {
  return std::bit_cast<float>(le_u32(p));
}

std::string text_field(const std::uint8_t* p, std::size_t size) {
  std::string text;
  for (std::size_t i = 0; i < size && p[i] != 0; ++i) text.push_back(static_cast<char>(p[i]));
  return text;
}

// The file header: what HeidelbergVol keeps of it, and where the thickness grid lies (read only to
// account for bytes after the last B-scan).
struct FileHeader {
  VolHeader fields;
  std::uint32_t grid_type = 0;
  std::uint32_t grid_offset = 0;
};

FileHeader read_file_header(std::istream& in, std::uint64_t file_bytes,
                            const std::filesystem::path& path) {
  std::vector<std::uint8_t> h(kFileHeaderBytes);
  if (!in.read(reinterpret_cast<char*>(h.data()), static_cast<std::streamsize>(h.size()))) {
    throw InputFileError(path, "truncated: " + std::to_string(file_bytes) +
                                   " bytes, shorter than the " + std::to_string(kFileHeaderBytes) +
                                   "-byte file header");
  }
  if (std::memcmp(h.data(), "HSF-OCT-", 8) != 0) {
    throw InputFileError(path, "not a Heidelberg .vol file (it does not start with HSF-OCT-)");
  }
  FileHeader file_header;
  VolHeader& header = file_header.fields;
  header.version = text_field(h.data(), 12);
  if (header.version.size() < 9 || header.version[8] != '1') {
    throw InputFileError(
        path, "version '" + quote_input(header.version) + "' is not supported (HSF-OCT-1xx only)");
  }
  header.ascans = le_u32(&h[12]);
  header.bscans = le_u32(&h[16]);
  header.depth = le_u32(&h[20]);
  header.ascan_spacing_mm = le_f64(&h[24]);
  header.bscan_distance_mm = le_f64(&h[32]);
  header.depth_spacing_mm = le_f64(&h[40]);
  header.slo_width = le_u32(&h[48]);
  header.slo_height = le_u32(&h[52]);
  header.slo_spacing_x_mm = le_f64(&h[56]);
  header.slo_spacing_y_mm = le_f64(&h[64]);
  header.scan_position = text_field(&h[84], 4);
  header.scan_pattern = static_cast<std::int32_t>(le_u32(&h[96]));
  header.bscan_header_bytes = le_u32(&h[100]);
  file_header.grid_type = le_u32(&h[208]);
  file_header.grid_offset = le_u32(&h[212]);
  return file_header;
}

// Bounds the sizes before anything is computed or allocated from them.
void check_header_values(const VolHeader& header, const std::filesystem::path& path) {
  const auto require_count = [&](const char* name, std::uint32_t value, std::uint32_t lo,
                                 std::uint32_t hi) {
    if (value < lo || value > hi) {
      throw InputFileError(path, std::string("file header: ") + name + " = " +
                                     std::to_string(value) + " is out of range [" +
                                     std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
  };
  require_count("size_x (A-scans per B-scan)", header.ascans, 1, 16384);
  require_count("number of B-scans", header.bscans, 1, 4096);
  require_count("size_y (pixels per A-scan)", header.depth, 1, 16384);
  require_count("SLO width", header.slo_width, 0, 16384);
  require_count("SLO height", header.slo_height, 0, 16384);
  require_count("B-scan header size", header.bscan_header_bytes, kBscanFixedBytes, 1u << 24);
  const auto require_spacing = [&](const char* name, double value, bool zero_allowed) {
    if (!std::isfinite(value) || value < 0 || (value == 0 && !zero_allowed) || value > 1000) {
      throw InputFileError(path, std::string("file header: ") + name + " = " +
                                     std::to_string(value) + " mm is not a plausible spacing");
    }
  };
  require_spacing("scale_x (A-scan spacing)", header.ascan_spacing_mm, false);
  require_spacing("scale_y (axial spacing)", header.depth_spacing_mm, false);
  require_spacing("distance (B-scan spacing)", header.bscan_distance_mm, true);
}

// Where the parts of the file lie, as the (checked) header says.
struct VolLayout {
  std::uint64_t slo_bytes = 0;
  std::uint64_t image_bytes = 0;  // one B-scan's image
  std::uint64_t bscan_bytes = 0;  // one B-scan's header and image
  std::uint64_t expected = 0;     // the whole file without a thickness grid
};

VolLayout layout_of(const VolHeader& header) {
  VolLayout layout;
  layout.slo_bytes = std::uint64_t{header.slo_width} * header.slo_height;
  layout.image_bytes = std::uint64_t{header.ascans} * header.depth * 4;
  layout.bscan_bytes = header.bscan_header_bytes + layout.image_bytes;
  layout.expected = kFileHeaderBytes + layout.slo_bytes + header.bscans * layout.bscan_bytes;
  return layout;
}

// The length is checked before reading, so a short file names the B-scan that is cut and a
// long one is refused rather than half read.
void check_file_length(const FileHeader& file_header, const VolLayout& layout,
                       std::uint64_t file_bytes, const std::filesystem::path& path) {
  const VolHeader& header = file_header.fields;
  const std::uint64_t expected = layout.expected;
  const std::string dims = std::to_string(header.bscans) + " B-scans of " +
                           std::to_string(header.ascans) + " x " + std::to_string(header.depth);
  if (file_bytes < expected) {
    const std::uint64_t before_bscans = kFileHeaderBytes + layout.slo_bytes;
    const std::string where =
        file_bytes < before_bscans
            ? "the SLO image is cut"
            : "B-scan " + std::to_string((file_bytes - before_bscans) / layout.bscan_bytes) +
                  " of " + std::to_string(header.bscans) + " is cut";
    throw InputFileError(path, "truncated: " + where + " (the file has " +
                                   std::to_string(file_bytes) + " bytes; its header's " + dims +
                                   " need " + std::to_string(expected) + ")");
  }
  if (file_bytes > expected &&
      !(file_header.grid_type != 0 && file_header.grid_offset >= expected &&
        file_header.grid_offset < file_bytes)) {
    throw InputFileError(path, std::to_string(file_bytes - expected) +
                                   " bytes after the last B-scan that no " +
                                   "thickness grid accounts for (the header's " + dims + " need " +
                                   std::to_string(expected) + " bytes)");
  }
}

// The segmentation lines stored in a B-scan header, "none" (above kNoValue) as NaN.
std::vector<std::vector<float>> decode_layers(const std::vector<std::uint8_t>& bh,
                                              std::uint32_t lines, std::uint32_t lines_offset,
                                              std::uint32_t ascans) {
  std::vector<std::vector<float>> layers(lines, std::vector<float>(ascans));
  for (std::uint32_t l = 0; l < lines; ++l) {
    const std::uint8_t* p = &bh[lines_offset + std::size_t{l} * ascans * 4];
    for (std::uint32_t a = 0; a < ascans; ++a) {
      const float value = le_f32(p + 4 * a);
      layers[l][a] = std::isfinite(value) && value < kNoValue ? value : std::nanf("");
    }
  }
  return layers;
}

// B-scan `b`: its header, segmentation lines and image. `bh` holds the header; it is the size the
// file header gives and serves every B-scan, so it is allocated once.
void read_bscan(std::istream& in, const VolHeader& header, std::uint32_t b,
                std::uint64_t image_bytes, std::vector<std::uint8_t>& bh, VolBscan& bscan,
                const std::filesystem::path& path) {
  const std::string where = "B-scan " + std::to_string(b) + ": ";
  in.read(reinterpret_cast<char*>(bh.data()), static_cast<std::streamsize>(bh.size()));
  if (!in) throw InputFileError(path, where + "read failed");
  if (std::memcmp(bh.data(), "HSF-BS-", 7) != 0) {
    throw InputFileError(path, where + "its header does not start with HSF-BS-");
  }
  if (le_u32(&bh[12]) != header.bscan_header_bytes) {
    throw InputFileError(path, where + "header size " + std::to_string(le_u32(&bh[12])) +
                                   " differs from the file header's " +
                                   std::to_string(header.bscan_header_bytes));
  }
  bscan.start_x_mm = le_f64(&bh[16]);
  bscan.start_y_mm = le_f64(&bh[24]);
  bscan.end_x_mm = le_f64(&bh[32]);
  bscan.end_y_mm = le_f64(&bh[40]);
  const std::uint32_t lines = le_u32(&bh[48]);
  const std::uint32_t lines_offset = le_u32(&bh[52]);
  bscan.quality = le_f32(&bh[56]);
  bscan.shift = static_cast<std::int32_t>(le_u32(&bh[60]));
  const std::uint64_t lines_end =
      std::uint64_t{lines_offset} + std::uint64_t{lines} * header.ascans * 4;
  if (lines > 64 || (lines > 0 && (lines_offset < 64 || lines_end > header.bscan_header_bytes))) {
    throw InputFileError(path, where + std::to_string(lines) + " segmentation lines of " +
                                   std::to_string(header.ascans) + " values at offset " +
                                   std::to_string(lines_offset) + " do not fit its header of " +
                                   std::to_string(header.bscan_header_bytes) + " bytes");
  }
  bscan.layers = decode_layers(bh, lines, lines_offset, header.ascans);
  bscan.intensity.resize(std::size_t{header.ascans} * header.depth);
  static_assert(std::endian::native == std::endian::little,
                "the .vol reader assumes a little-endian host");
  in.read(reinterpret_cast<char*>(bscan.intensity.data()),
          static_cast<std::streamsize>(image_bytes));
  if (!in) {
    throw InputFileError(
        path, where + "read of its " + std::to_string(image_bytes) + " image bytes failed");
  }
}

}  // namespace

std::string layer_name(std::size_t index) {
  static const char* const kNames[] = {"ILM", "BM", "RNFL"};
  return index < 3 ? kNames[index] : "line" + std::to_string(index);
}

std::string_view scan_pattern_name(std::int32_t pattern) noexcept {
  switch (pattern) {
    case 1:
      return "line";
    case 2:
      return "circle";
    case 3:
      return "volume (ART)";
    case 4:
      return "fast volume";
    case 5:
      return "radial";
    default:
      return "unknown";
  }
}

HeidelbergVol read_heidelberg_vol(const std::filesystem::path& path) {
  const std::uint64_t file_bytes = checked_input_size(path);  // before a FIFO could block
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputFileError(path, std::string("cannot open: ") + std::strerror(errno));

  const FileHeader file_header = read_file_header(in, file_bytes, path);
  const VolHeader& header = file_header.fields;
  check_header_values(header, path);
  const VolLayout layout = layout_of(header);
  check_file_length(file_header, layout, file_bytes, path);

  HeidelbergVol vol;
  vol.header = header;
  vol.slo.resize(layout.slo_bytes);
  in.read(reinterpret_cast<char*>(vol.slo.data()), static_cast<std::streamsize>(layout.slo_bytes));
  std::vector<std::uint8_t> bh(header.bscan_header_bytes);
  vol.bscans.resize(header.bscans);
  for (std::uint32_t b = 0; b < header.bscans; ++b) {
    read_bscan(in, header, b, layout.image_bytes, bh, vol.bscans[b], path);
  }
  return vol;
}

Volume to_volume(const HeidelbergVol& vol) {
  const VolHeader& h = vol.header;
  Volume volume(h.bscans, h.ascans, h.depth);
  for (std::uint32_t b = 0; b < h.bscans; ++b) {
    auto pixels = volume.bscan(b);
    const std::vector<float>& image = vol.bscans[b].intensity;
    for (std::uint32_t y = 0; y < h.depth; ++y) {
      for (std::uint32_t x = 0; x < h.ascans; ++x) {
        const float v = image[std::size_t{y} * h.ascans + x];
        std::uint8_t pixel = 0;
        if (v >= 1.0f && v < kNoValue) {
          pixel = 255;
        } else if (v > 0.0f && v < 1.0f) {  // false for NaN and "no data"
          pixel = static_cast<std::uint8_t>(std::lround(255.0 * std::pow(double{v}, 0.25)));
        }
        pixels[std::size_t{x} * h.depth + y] = pixel;
      }
    }
  }
  return volume;
}

}  // namespace ioct::gpu::offline
