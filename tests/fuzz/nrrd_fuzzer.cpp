// The NRRD volume reader (gpu/offline nrrd_file), as ioct-segment and ioct-render call it, on a
// file of the fuzzer's bytes. A volume it accepts must hold exactly the voxels its sizes say.
#include <cstddef>
#include <cstdint>

#include "input_files.hpp"
#include "ioct/gpu/offline/nrrd_file.hpp"
#include "refusal.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ioct::fuzz::MemoryFile file("volume.nrrd");
  file.assign(data, size);
  ioct::fuzz::expect_accept_or_refuse(
      [&] {
        const auto nrrd = ioct::gpu::offline::read_nrrd_file(file.path());
        const auto& v = nrrd.volume;
        const std::size_t voxels = std::size_t{v.bscans()} * v.ascans() * v.depth();
        if (voxels == 0 || voxels > size) {
          ioct::fuzz::finding("accepted a NRRD whose voxels the file cannot hold", "");
        }
      },
      file.path().string());
  return 0;
}
