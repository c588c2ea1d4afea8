// The Bioptigen .OCT reader (gpu/offline bioptigen_oct), as ioct-vol-import, ioct-segment and
// ioct-render call it, on a file of the fuzzer's bytes; an accepted file is also averaged into
// the u8 volume, as they all do next. An accepted file must hold the samples it claims.
#include <cstddef>
#include <cstdint>

#include "input_files.hpp"
#include "ioct/gpu/offline/bioptigen_oct.hpp"
#include "refusal.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ioct::fuzz::MemoryFile file("export.OCT");
  file.assign(data, size);
  ioct::fuzz::expect_accept_or_refuse(
      [&] {
        const auto oct = ioct::gpu::offline::read_bioptigen_oct(file.path());
        const auto& h = oct.header;
        const std::size_t samples = std::size_t{h.frame_count} * h.ascans * h.depth;
        if (samples == 0 || oct.samples.size() != samples || samples * 2 > size) {
          ioct::fuzz::finding("accepted a .OCT whose samples the file cannot hold", "");
        }
        const auto out = ioct::gpu::offline::to_volume(oct);
        if (out.volume.bscans() != oct.positions || out.volume.ascans() != h.ascans ||
            out.volume.depth() != h.depth || out.window_high <= out.window_low) {
          ioct::fuzz::finding("to_volume's volume differs from the file's geometry", "");
        }
        (void)ioct::gpu::offline::spacing_mm(oct);
      },
      file.path().string());
  return 0;
}
