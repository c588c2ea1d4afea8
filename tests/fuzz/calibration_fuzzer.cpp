// The resampling calibration file (gpu/offline calibration_file), as ioct-process reads its
// --calibration, on a file of the fuzzer's bytes: coefficients separated by commas, spaces or
// newlines, '#' comments.
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "input_files.hpp"
#include "ioct/gpu/offline/calibration_file.hpp"
#include "refusal.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ioct::fuzz::MemoryFile file("calibration.txt");
  file.assign(data, size);
  ioct::fuzz::expect_accept_or_refuse(
      [&] {
        const auto coefficients = ioct::gpu::offline::read_calibration_file(file.path());
        if (coefficients.empty()) ioct::fuzz::finding("accepted a file of no coefficients", "");
      },
      file.path().string());
  return 0;
}
