#include "ioct/gpu/offline/bioptigen_oct.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "ioct/common/input_file.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"

namespace ioct::gpu::offline {
namespace {

constexpr std::uint32_t kMaxKeyBytes = 64;      // the longest known key is 15
constexpr std::uint32_t kMaxDimension = 65536;  // A-scans or samples (NRRD's limit too)
constexpr std::uint32_t kMaxFrames = 1u << 20;
constexpr double kMaxLengthMm = 1000.0;

std::uint32_t le_u32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 |
         std::uint32_t{p[3]} << 24;
}

// Reads the file front to back, every read checked against the file's size first, so a length
// field can never make it allocate or seek past what the file holds.
class Cursor {
 public:
  Cursor(const std::filesystem::path& path, std::uint64_t size) : path_(path), size_(size) {
    in_.open(path, std::ios::binary);
    if (!in_) throw fail(std::string("cannot open: ") + std::strerror(errno));
  }

  InputFileError fail(const std::string& problem) const { return InputFileError(path_, problem); }
  std::uint64_t offset() const noexcept { return offset_; }
  std::uint64_t left() const noexcept { return size_ - offset_; }
  std::uint64_t size() const noexcept { return size_; }

  void read(void* out, std::uint64_t bytes, const std::string& what) {
    need(bytes, what);
    in_.read(static_cast<char*>(out), static_cast<std::streamsize>(bytes));
    if (!in_) throw fail("read of " + what + " at offset " + std::to_string(offset_) + " failed");
    offset_ += bytes;
  }
  void skip(std::uint64_t bytes, const std::string& what) {
    need(bytes, what);
    in_.seekg(static_cast<std::streamoff>(bytes), std::ios::cur);
    if (!in_) throw fail("seek over " + what + " at offset " + std::to_string(offset_) + " failed");
    offset_ += bytes;
  }
  std::uint32_t u32(const std::string& what) {
    std::uint8_t b[4];
    read(b, 4, what);
    return le_u32(b);
  }

 private:
  void need(std::uint64_t bytes, const std::string& what) const {
    if (bytes > left()) {
      throw fail("truncated: " + what + " at offset " + std::to_string(offset_) + " needs " +
                 std::to_string(bytes) + " bytes, the file has " + std::to_string(left()) +
                 " left (" + std::to_string(size_) + " in all)");
    }
  }

  std::filesystem::path path_;
  std::uint64_t size_;
  std::uint64_t offset_ = 0;
  std::ifstream in_;
};

struct Tag {
  std::string key;           // empty: the end of a header or frame
  std::uint64_t offset = 0;  // of the key length
  std::uint32_t data_bytes = 0;
};

Tag read_tag(Cursor& in, const std::string& where) {
  Tag tag;
  tag.offset = in.offset();
  const std::uint32_t key_bytes = in.u32(where + ": key length");
  if (key_bytes == 0) return tag;
  if (key_bytes > kMaxKeyBytes) {
    throw in.fail(where + ": key length " + std::to_string(key_bytes) + " at offset " +
                  std::to_string(tag.offset) + " is not a key (at most " +
                  std::to_string(kMaxKeyBytes) + " bytes)");
  }
  tag.key.resize(key_bytes);
  in.read(tag.key.data(), key_bytes, where + ": key");
  for (const char c : tag.key) {
    if (c < 0x20 || c > 0x7e) {
      throw in.fail(where + ": key " + quote_input(tag.key) + " at offset " +
                    std::to_string(tag.offset) + " is not printable text");
    }
  }
  tag.data_bytes = in.u32(where + ": data length of " + tag.key);
  return tag;
}

std::string at(const Tag& tag) {
  return tag.key + " (offset " + std::to_string(tag.offset) + ")";
}

std::uint32_t read_uint(Cursor& in, const Tag& tag) {
  if (tag.data_bytes != 1 && tag.data_bytes != 2 && tag.data_bytes != 4 && tag.data_bytes != 8) {
    throw in.fail(at(tag) + ": data length " + std::to_string(tag.data_bytes) +
                  " is not that of an integer (1, 2, 4 or 8 bytes)");
  }
  std::uint8_t b[8] = {};
  in.read(b, tag.data_bytes, tag.key);
  std::uint64_t value = 0;
  for (std::uint32_t i = 0; i < tag.data_bytes; ++i) value |= std::uint64_t{b[i]} << (8 * i);
  if (value > 0xffffffffu) {
    throw in.fail(at(tag) + " = " + std::to_string(value) + " is out of range");
  }
  return static_cast<std::uint32_t>(value);
}

double read_f64(Cursor& in, const Tag& tag) {
  if (tag.data_bytes != 8) {
    throw in.fail(at(tag) + ": data length " + std::to_string(tag.data_bytes) +
                  " is not that of a f64 (8)");
  }
  std::uint8_t b[8];
  in.read(b, 8, tag.key);
  const std::uint64_t bits = std::uint64_t{le_u32(b)} | std::uint64_t{le_u32(b + 4)} << 32;
  return std::bit_cast<double>(bits);
}

void require_range(Cursor& in, const Tag& tag, std::uint32_t value, std::uint32_t lo,
                   std::uint32_t hi) {
  if (value < lo || value > hi) {
    throw in.fail(at(tag) + " = " + std::to_string(value) + " is out of range [" +
                  std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
}

double read_length_mm(Cursor& in, const Tag& tag) {
  const double value = read_f64(in, tag);
  if (!std::isfinite(value) || value < 0 || value > kMaxLengthMm) {
    throw in.fail(at(tag) + " = " + std::to_string(value) + " mm is not a length in [0, " +
                  std::to_string(static_cast<int>(kMaxLengthMm)) + "] mm");
  }
  return value;
}

// Where the counts were found, for messages about their consistency ("absent" when not).
struct CountOffsets {
  std::string frame_count = "absent", scans = "absent", frames = "absent";
};

// The file header's fields after FRAMEHEADER, up to the end marker (or FRAMEDATA in a file that
// has none). Returns the tag that ended it.
Tag read_file_header(Cursor& in, BioptigenHeader& h, CountOffsets& offsets) {
  bool have_count = false, have_lines = false, have_length = false;
  for (;;) {
    const Tag tag = read_tag(in, "file header");
    if (tag.key.empty() || tag.key == "FRAMEDATA") {
      if (!have_count || !have_lines || !have_length) {
        throw in.fail("file header ends at offset " + std::to_string(tag.offset) + " without " +
                      (!have_count   ? "FRAMECOUNT"
                       : !have_lines ? "LINECOUNT"
                                     : "LINELENGTH"));
      }
      return tag;
    }
    if (tag.key == "FRAMECOUNT") {
      h.frame_count = read_uint(in, tag);
      require_range(in, tag, h.frame_count, 1, kMaxFrames);
      offsets.frame_count = "offset " + std::to_string(tag.offset);
      have_count = true;
    } else if (tag.key == "LINECOUNT") {
      h.ascans = read_uint(in, tag);
      require_range(in, tag, h.ascans, 1, kMaxDimension);
      have_lines = true;
    } else if (tag.key == "LINELENGTH") {
      h.depth = read_uint(in, tag);
      require_range(in, tag, h.depth, 1, kMaxDimension);
      have_length = true;
    } else if (tag.key == "SAMPLEFORMAT") {
      h.sample_format = read_uint(in, tag);
    } else if (tag.key == "SCANTYPE") {
      h.scan_type = read_uint(in, tag);
      require_range(in, tag, h.scan_type, 0, 6);
      if (h.scan_type == 6) {
        throw in.fail(at(tag) + " = 6 (mixed density): not supported (its frames differ in size)");
      }
    } else if (tag.key == "SCANDEPTH") {
      h.scan_depth_mm = read_length_mm(in, tag);
    } else if (tag.key == "SCANLENGTH") {
      h.scan_length_mm = read_length_mm(in, tag);
    } else if (tag.key == "AZSCANLENGTH") {
      h.az_scan_length_mm = read_length_mm(in, tag);
    } else if (tag.key == "ELSCANLENGTH") {
      h.el_scan_length_mm = read_length_mm(in, tag);
    } else if (tag.key == "SCANS" || (tag.key == "FRAMESPERVOLUME" && !h.scans)) {
      h.scans = read_uint(in, tag);
      require_range(in, tag, *h.scans, 1, kMaxDimension);  // B-scans of the volume
      offsets.scans = (tag.key == "SCANS" ? "" : tag.key + " at ") + std::string("offset ") +
                      std::to_string(tag.offset);
    } else if (tag.key == "FRAMES") {
      h.frames_per_scan = read_uint(in, tag);
      require_range(in, tag, *h.frames_per_scan, 1, kMaxFrames);
      offsets.frames = "offset " + std::to_string(tag.offset);
    } else if (tag.key == "DOPPLERFLAG") {
      const std::uint32_t flag = read_uint(in, tag);
      require_range(in, tag, flag, 0, 1);
      h.doppler = flag == 1;
    } else if (tag.key == "DESCRIPTION") {
      std::string text(std::min<std::uint32_t>(tag.data_bytes, 4096), '\0');
      in.read(text.data(), text.size(), tag.key);
      in.skip(tag.data_bytes - text.size(), tag.key);
      h.description = quote_input(text.substr(0, text.find('\0')), 200);
    } else {
      in.skip(tag.data_bytes, at(tag));  // captions, ranges, CONFIG, SUBFRAME*, unknown keys
    }
  }
}

// One frame after its FRAMEDATA marker: its samples into `out` (ascans x depth u16).
void read_frame(Cursor& in, const BioptigenHeader& h, std::uint32_t frame, std::uint16_t* out) {
  const std::string where = "frame " + std::to_string(frame);
  const std::uint64_t sample_bytes = std::uint64_t{h.ascans} * h.depth * 2;
  bool have_samples = false;
  for (;;) {
    if (have_samples && in.left() == 0 && frame + 1 == h.frame_count) return;  // no end marker
    const Tag tag = read_tag(in, where);
    if (tag.key.empty()) {
      if (!have_samples) {
        throw in.fail(where + " ends at offset " + std::to_string(tag.offset) +
                      " without FRAMESAMPLES");
      }
      return;
    }
    if (tag.key == "FRAMELINES") {
      const std::uint32_t lines = read_uint(in, tag);
      if (lines != h.ascans) {
        throw in.fail(where + ": " + at(tag) + " = " + std::to_string(lines) +
                      " differs from the header's LINECOUNT " + std::to_string(h.ascans));
      }
    } else if (tag.key == "FRAMESAMPLES") {
      if (tag.data_bytes != sample_bytes) {
        throw in.fail(where + ": " + at(tag) + ": data length " + std::to_string(tag.data_bytes) +
                      " is not LINECOUNT x LINELENGTH x 2 = " + std::to_string(sample_bytes));
      }
      if (have_samples) throw in.fail(where + ": a second " + at(tag));
      static_assert(std::endian::native == std::endian::little,
                    "the .OCT reader assumes a little-endian host");
      in.read(out, sample_bytes, where + ": " + at(tag));
      have_samples = true;
    } else if (tag.key == "FRAMEDATA") {
      throw in.fail(where + ": " + at(tag) + " before the frame's end marker");
    } else {
      in.skip(tag.data_bytes, where + ": " + at(tag));  // times, DOPPLERSAMPLES, unknown keys
    }
  }
}

}  // namespace

bool has_bioptigen_magic(const std::uint8_t* head, std::size_t size) noexcept {
  return size >= 4 && le_u32(head) == kBioptigenMagic;
}

BioptigenOct read_bioptigen_oct(const std::filesystem::path& path) {
  const std::uint64_t file_bytes = checked_input_size(path);  // before a FIFO could block
  Cursor in(path, file_bytes);
  std::uint8_t start[6];
  in.read(start, 6, "magic number and version");
  if (!has_bioptigen_magic(start, 6)) {
    throw in.fail("not a Bioptigen .OCT file (magic number 0x" + [&] {
      char hex[9];
      std::snprintf(hex, sizeof hex, "%08X", le_u32(start));
      return std::string(hex);
    }() + " at offset 0; expected 0x0C7DA7A5)");
  }
  BioptigenOct oct;
  BioptigenHeader& h = oct.header;
  h.version = static_cast<std::uint16_t>(start[4] | start[5] << 8);
  const Tag first = read_tag(in, "file header");
  if (first.key != "FRAMEHEADER") {
    throw in.fail("file header: the first key at offset 6 is " +
                  (first.key.empty() ? std::string("empty") : quote_input(first.key)) +
                  ", not FRAMEHEADER");
  }
  CountOffsets offsets;
  const Tag end = read_file_header(in, h, offsets);

  // Positions and repeats from SCANS and FRAMES, checked against FRAMECOUNT.
  const std::uint32_t scans =
      h.scans.value_or(h.frame_count / std::max(1u, h.frames_per_scan.value_or(1)));
  const std::uint64_t repeats = h.frames_per_scan.value_or(h.frame_count / std::max(1u, scans));
  if (scans == 0 || repeats == 0 || std::uint64_t{scans} * repeats != h.frame_count) {
    throw in.fail("file header: FRAMECOUNT (" + offsets.frame_count +
                  ") = " + std::to_string(h.frame_count) + " is not SCANS (" + offsets.scans +
                  ") " + std::to_string(scans) + " x FRAMES (" + offsets.frames + ") " +
                  std::to_string(repeats));
  }
  const bool one_position = h.scan_type == 0 || h.scan_type == 5;  // linear, M-mode
  oct.positions = one_position ? 1 : scans;
  if (oct.positions > kMaxDimension) {  // FRAMECOUNT frames without SCANS, all positions
    throw in.fail("file header: FRAMECOUNT (" + offsets.frame_count + ") = " +
                  std::to_string(h.frame_count) + " B-scan positions (no SCANS or FRAMES) are " +
                  "more than " + std::to_string(kMaxDimension));
  }
  oct.repeats = one_position ? h.frame_count : static_cast<std::uint32_t>(repeats);

  // The frames must fit in what is left of the file before anything is allocated for them.
  const std::uint64_t frame_bytes = std::uint64_t{h.ascans} * h.depth * 2;
  const std::uint64_t all_bytes = frame_bytes * h.frame_count;  // < 2^33 * 2^20: no overflow
  if (all_bytes > in.left()) {
    throw in.fail("truncated: FRAMECOUNT " + std::to_string(h.frame_count) + " frames of " +
                  std::to_string(h.ascans) + " x " + std::to_string(h.depth) + " u16 need " +
                  std::to_string(all_bytes) + " bytes, the file has " + std::to_string(in.left()) +
                  " after its header (offset " + std::to_string(in.offset()) + ")");
  }
  oct.samples.resize(all_bytes / 2);
  for (std::uint32_t f = 0; f < h.frame_count; ++f) {
    const Tag marker =
        f == 0 && end.key == "FRAMEDATA" ? end : read_tag(in, "frame " + std::to_string(f));
    if (marker.key != "FRAMEDATA") {
      throw in.fail("frame " + std::to_string(f) + " of " + std::to_string(h.frame_count) +
                    ": expected FRAMEDATA at offset " + std::to_string(marker.offset) + ", found " +
                    (marker.key.empty() ? std::string("an end marker") : quote_input(marker.key)));
    }
    read_frame(in, h, f, oct.samples.data() + f * (frame_bytes / 2));
  }
  if (in.left() != 0) {
    throw in.fail(std::to_string(in.left()) + " bytes after the last of FRAMECOUNT " +
                  std::to_string(h.frame_count) + " frames (offset " + std::to_string(in.offset()) +
                  ")");
  }
  return oct;
}

BioptigenVolume to_volume(const BioptigenOct& oct, std::optional<std::uint32_t> repeat) {
  const BioptigenHeader& h = oct.header;
  if (repeat && *repeat >= oct.repeats) {
    throw std::out_of_range("repeat " + std::to_string(*repeat) + " (the file has " +
                            std::to_string(oct.repeats) + " frames per position)");
  }
  const std::size_t frame = std::size_t{h.ascans} * h.depth;
  // Frame f is position f % positions of repeat f / positions.
  const std::size_t voxels = std::size_t{oct.positions} * frame;
  std::vector<std::uint32_t> histogram(65536, 0);
  const std::uint32_t first = repeat.value_or(0);
  const std::uint32_t count = repeat ? 1 : oct.repeats;
  // One frame per position is used as it is: a repeat's frames are contiguous, so no copy.
  std::vector<std::uint16_t> averaged;
  const std::uint16_t* mean = oct.samples.data() + std::size_t{first} * voxels;
  if (count > 1) {
    averaged.resize(voxels);
    std::vector<std::uint64_t> sum(frame);
    for (std::uint32_t p = 0; p < oct.positions; ++p) {
      std::fill(sum.begin(), sum.end(), 0);
      for (std::uint32_t r = first; r < first + count; ++r) {
        const std::uint16_t* s = oct.samples.data() + (std::size_t{r} * oct.positions + p) * frame;
        for (std::size_t i = 0; i < frame; ++i) sum[i] += s[i];
      }
      std::uint16_t* m = averaged.data() + p * frame;
      for (std::size_t i = 0; i < frame; ++i) {
        m[i] = static_cast<std::uint16_t>((sum[i] + count / 2) / count);  // rounded mean
      }
    }
    mean = averaged.data();
  }
  for (std::size_t i = 0; i < voxels; ++i) ++histogram[mean[i]];
  // The value at rank n * permille / 1000 of the sorted means.
  const auto percentile = [&](std::uint64_t permille) {
    const std::uint64_t target = voxels * permille / 1000;
    std::uint64_t seen = 0;
    for (std::uint32_t v = 0; v < 65536; ++v) {
      seen += histogram[v];
      if (seen > target) return static_cast<std::uint16_t>(v);
    }
    return std::uint16_t{65535};
  };
  BioptigenVolume out;
  out.window_low = percentile(5);
  out.window_high = percentile(999);
  if (out.window_high <= out.window_low) {  // a flat image: a window of one step
    out.window_low = std::min<std::uint16_t>(out.window_low, 65534);
    out.window_high = static_cast<std::uint16_t>(out.window_low + 1);
  }
  const double scale = 255.0 / (out.window_high - out.window_low);
  out.volume = Volume(oct.positions, h.ascans, h.depth);
  std::uint8_t* voxel = out.volume.pixels().data();
  for (std::size_t i = 0; i < voxels; ++i) {
    const double v = (static_cast<double>(mean[i]) - out.window_low) * scale;
    voxel[i] = static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 255.0)));
  }
  return out;
}

BioptigenSpacingMm spacing_mm(const BioptigenOct& oct) noexcept {
  const BioptigenHeader& h = oct.header;
  BioptigenSpacingMm s;
  if (h.depth > 0) s.depth = h.scan_depth_mm / h.depth;
  const double lateral =
      h.scan_type == 1 && h.az_scan_length_mm > 0 ? h.az_scan_length_mm : h.scan_length_mm;
  if (h.ascans > 0) s.ascan = lateral / h.ascans;
  if (h.scan_type == 1 && oct.positions > 1) s.bscan = h.el_scan_length_mm / oct.positions;
  return s;
}

std::string_view bioptigen_scan_type_name(std::uint32_t scan_type) noexcept {
  switch (scan_type) {
    case 0:
      return "linear";
    case 1:
      return "rectangular volume";
    case 3:
      return "radial";
    case 5:
      return "M-mode";
    case 6:
      return "mixed density";
    default:
      return "unknown";
  }
}

}  // namespace ioct::gpu::offline
