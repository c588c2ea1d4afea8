// The Heidelberg .vol reader (gpu/offline heidelberg_vol), as ioct-vol-import, ioct-segment and
// ioct-render call it, on a file of the fuzzer's bytes; an accepted file is also converted to the
// u8 volume, as they all do next.
#include <cstddef>
#include <cstdint>

#include "input_files.hpp"
#include "ioct/gpu/offline/heidelberg_vol.hpp"
#include "refusal.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ioct::fuzz::MemoryFile file("export.vol");
  file.assign(data, size);
  ioct::fuzz::expect_accept_or_refuse(
      [&] {
        const auto vol = ioct::gpu::offline::read_heidelberg_vol(file.path());
        const auto volume = ioct::gpu::offline::to_volume(vol);
        if (volume.bscans() != vol.bscans.size()) {
          ioct::fuzz::finding("to_volume lost B-scans", "");
        }
        for (std::size_t i = 0; i < vol.bscans.front().layers.size(); ++i) {
          (void)ioct::gpu::offline::layer_name(i);
        }
      },
      file.path().string());
  return 0;
}
