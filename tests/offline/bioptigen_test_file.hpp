// Synthetic Bioptigen .OCT files written from the documented layout (see
// gpu/offline/include/ioct/gpu/offline/bioptigen_oct.hpp): a few frames of a known retina, so the
// reader's geometry and every sample can be checked, and bytes the tests cut and patch. The fuzz
// seeds (tests/fuzz/corpus/bioptigen_oct/) are files of this writer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ioct::gpu::offline::testing {

struct BioptigenSpec {
  std::uint32_t ascans = 12;          // LINECOUNT
  std::uint32_t depth = 40;           // LINELENGTH
  std::uint32_t scans = 3;            // B-scan positions
  std::uint32_t frames = 2;           // frames per position
  std::uint32_t scan_type = 1;        // rectangular volume
  bool scans_and_frames_keys = true;  // SCANS + FRAMES (v1.7); false: FRAMESPERVOLUME only
  bool doppler = false;               // DOPPLERFLAG 1 and DOPPLERSAMPLES in every frame
  double scan_depth_mm = 1.6, scan_length_mm = 2.4, az_scan_length_mm = 2.4,
         el_scan_length_mm = 0.6;
  std::string description = "synthetic retina";
};

// The known retina: the inner limiting membrane's depth row at B-scan position p, A-scan a, and
// sample s of A-scan a in frame f (log intensity as u16: dark vitreous, a bright retina from the
// ILM on, a brighter RPE band, a little darker below; each frame offset by its repeat).
std::uint32_t bioptigen_ilm_row(const BioptigenSpec& spec, std::uint32_t position, std::uint32_t a);
std::uint16_t bioptigen_sample(const BioptigenSpec& spec, std::uint32_t frame, std::uint32_t a,
                               std::uint32_t s);

std::vector<std::uint8_t> make_bioptigen_bytes(const BioptigenSpec& spec);

// Offset of the data of the first field named `key` at or after `from` (after its key length,
// key and data length), for patching; throws when there is none.
std::size_t bioptigen_field_data(const std::vector<std::uint8_t>& bytes, const std::string& key,
                                 std::size_t from = 0);

}  // namespace ioct::gpu::offline::testing
