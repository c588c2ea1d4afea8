// The raw recording reader (recording/raw), as ioct-process and the replay digitizer use it: the
// metadata (rec.json), then every group record and its ground truth. The input is
//   <rec.json text> NUL <u32 LE: bytes of rec.raw> <rec.raw> <rec.truth>
// so the seeds (tests/fuzz/corpus/recording/) are small real recordings in one file; the
// metadata must name "rec.raw" and "rec.truth" for the data to be read.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "input_files.hpp"
#include "ioct/recording/recording_reader.hpp"
#include "refusal.hpp"

namespace {

// Reads at most this many groups of an accepted recording: enough to reach every record of the
// small inputs the fuzzer makes, bounded for the ones whose metadata claims millions.
constexpr std::uint64_t kGroupsRead = 64;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ioct::fuzz::ScratchDirectory dir;
  const auto* nul = static_cast<const std::uint8_t*>(std::memchr(data, 0, size));
  const std::size_t json_bytes = nul ? static_cast<std::size_t>(nul - data) : size;
  const std::uint8_t* rest = data + std::min(size, json_bytes + 1);
  std::size_t rest_bytes = size - std::min(size, json_bytes + 1);
  std::uint32_t raw_bytes = 0;
  if (rest_bytes >= 4) {
    std::memcpy(&raw_bytes, rest, 4);
    rest += 4;
    rest_bytes -= 4;
  }
  raw_bytes = static_cast<std::uint32_t>(std::min<std::size_t>(raw_bytes, rest_bytes));
  const auto json = dir.write("rec.json", data, json_bytes);
  dir.write("rec.raw", rest, raw_bytes);
  dir.write("rec.truth", rest + raw_bytes, rest_bytes - raw_bytes);

  ioct::fuzz::expect_accept_or_refuse(
      [&] {
        const ioct::recording::RecordingReader reader(json);
        const std::uint64_t words = reader.geometry().samples_per_group();
        // A geometry the metadata check let through must be one a reader can hold.
        if (words > (std::uint64_t{1} << 28)) {
          ioct::fuzz::finding("accepted a recording whose group cannot be held in memory", "");
        }
        std::vector<std::uint16_t> payload(words);
        ioct::recording::RecordedGroupInfo info;
        ioct::recording::GroupTruth truth;
        for (std::uint64_t g = 0; g < std::min(reader.group_count(), kGroupsRead); ++g) {
          ioct::fuzz::expect_accept_or_refuse(
              [&] {
                reader.read_group(g, payload, info);
                if (reader.has_truth()) reader.read_truth(g, truth);
              },
              dir.path().string());
        }
      },
      dir.path().string());
  return 0;
}
