#include "bioptigen_test_file.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <stdexcept>

namespace ioct::gpu::offline::testing {
namespace {

class Writer {
 public:
  void u16(std::uint16_t v) {
    bytes.push_back(static_cast<std::uint8_t>(v));
    bytes.push_back(static_cast<std::uint8_t>(v >> 8));
  }
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void key(const std::string& k, std::uint32_t data_bytes) {
    u32(static_cast<std::uint32_t>(k.size()));
    bytes.insert(bytes.end(), k.begin(), k.end());
    u32(data_bytes);
  }
  void uint_field(const std::string& k, std::uint32_t v) {
    key(k, 4);
    u32(v);
  }
  void f64_field(const std::string& k, double v) {
    key(k, 8);
    const auto bits = std::bit_cast<std::uint64_t>(v);
    u32(static_cast<std::uint32_t>(bits));
    u32(static_cast<std::uint32_t>(bits >> 32));
  }
  void text_field(const std::string& k, const std::string& text) {
    key(k, static_cast<std::uint32_t>(text.size()));
    bytes.insert(bytes.end(), text.begin(), text.end());
  }
  void end() { u32(0); }

  std::vector<std::uint8_t> bytes;
};

}  // namespace

std::uint32_t bioptigen_ilm_row(const BioptigenSpec& spec, std::uint32_t position,
                                std::uint32_t a) {
  // A shallow bowl, a little deeper at every position.
  const std::uint32_t centre = spec.ascans / 2;
  const std::uint32_t off = a > centre ? a - centre : centre - a;
  return spec.depth / 4 + position + off / 3;
}

std::uint16_t bioptigen_sample(const BioptigenSpec& spec, std::uint32_t frame, std::uint32_t a,
                               std::uint32_t s) {
  const std::uint32_t positions = spec.scan_type == 0 || spec.scan_type == 5 ? 1 : spec.scans;
  const std::uint32_t position = frame % positions;
  const std::uint32_t repeat = frame / positions;
  const std::uint32_t ilm = bioptigen_ilm_row(spec, position, a);
  const std::uint32_t rpe = ilm + spec.depth / 3;
  std::uint32_t v = 0;
  if (s < ilm) {
    v = 2000 + (a * 7 + s * 13) % 500;  // vitreous: dark, a fixed texture
  } else if (s < rpe) {
    v = 30000 + (s - ilm) * 100;  // retina
  } else if (s < rpe + 3) {
    v = 52000;  // RPE
  } else {
    v = 20000 - std::min<std::uint32_t>((s - rpe) * 500, 15000);  // choroid fading
  }
  return static_cast<std::uint16_t>(v + repeat * 300);
}

std::vector<std::uint8_t> make_bioptigen_bytes(const BioptigenSpec& spec) {
  Writer w;
  const std::uint32_t frame_count = spec.scans * spec.frames;
  w.u32(0x0C7DA7A5);
  w.u16(0x010A);
  w.key("FRAMEHEADER", 0);
  w.uint_field("FRAMECOUNT", frame_count);
  w.uint_field("LINECOUNT", spec.ascans);
  w.uint_field("LINELENGTH", spec.depth);
  w.uint_field("SAMPLEFORMAT", 2);
  w.text_field("DESCRIPTION", spec.description);
  w.f64_field("XMIN", 0.0);
  w.f64_field("XMAX", spec.scan_length_mm);
  w.text_field("XCAPTION", "Lateral (mm)");
  w.f64_field("YMIN", 0.0);
  w.f64_field("YMAX", spec.scan_depth_mm);
  w.text_field("YCAPTION", "Depth (mm)");
  w.uint_field("SCANTYPE", spec.scan_type);
  w.f64_field("SCANDEPTH", spec.scan_depth_mm);
  w.f64_field("SCANLENGTH", spec.scan_length_mm);
  w.f64_field("AZSCANLENGTH", spec.az_scan_length_mm);
  w.f64_field("ELSCANLENGTH", spec.el_scan_length_mm);
  w.f64_field("OBJECTDISTANCE", 12.5);
  w.f64_field("SCANANGLE", 0.0);
  if (spec.scans_and_frames_keys) {
    w.uint_field("SCANS", spec.scans);
    w.uint_field("FRAMES", spec.frames);
  } else {
    w.uint_field("FRAMESPERVOLUME", spec.scans);
  }
  w.uint_field("DOPPLERFLAG", spec.doppler ? 1 : 0);
  w.text_field("CONFIG", std::string("\x13\x37obfuscated\x01", 13));
  w.end();
  const std::uint32_t sample_bytes = spec.ascans * spec.depth * 2;
  for (std::uint32_t f = 0; f < frame_count; ++f) {
    w.key("FRAMEDATA", 0);
    w.key("FRAMEDATETIME", 16);
    const std::uint16_t system_time[8] = {
        2026, 11, 3, 25, 22, 15, static_cast<std::uint16_t>(f % 60), 500};
    for (const std::uint16_t v : system_time) w.u16(v);
    w.f64_field("FRAMETIMESTAMP", 1000.0 + 25.0 * f);
    w.uint_field("FRAMELINES", spec.ascans);
    w.key("FRAMESAMPLES", sample_bytes);
    for (std::uint32_t a = 0; a < spec.ascans; ++a) {
      for (std::uint32_t s = 0; s < spec.depth; ++s) w.u16(bioptigen_sample(spec, f, a, s));
    }
    if (spec.doppler) {
      w.key("DOPPLERSAMPLES", sample_bytes);
      for (std::uint32_t i = 0; i < spec.ascans * spec.depth; ++i) {
        w.u16(static_cast<std::uint16_t>(0x8000 + i % 0x8000));
      }
    }
    w.end();
  }
  return std::move(w.bytes);
}

std::size_t bioptigen_field_data(const std::vector<std::uint8_t>& bytes, const std::string& key,
                                 std::size_t from) {
  for (std::size_t i = std::max<std::size_t>(from, 4); i + 8 + key.size() <= bytes.size(); ++i) {
    const std::uint32_t length = bytes[i - 4] | bytes[i - 3] << 8 | bytes[i - 2] << 16 |
                                 static_cast<std::uint32_t>(bytes[i - 1]) << 24;
    if (length == key.size() && std::memcmp(&bytes[i], key.data(), key.size()) == 0) {
      return i + key.size() + 4;
    }
  }
  throw std::runtime_error("no field " + key + " in the synthetic file");
}

}  // namespace ioct::gpu::offline::testing
