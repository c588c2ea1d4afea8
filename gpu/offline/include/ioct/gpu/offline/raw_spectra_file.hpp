// Raw spectra recorded to a file: u16 samples [bscan][ascan][sample], samples contiguous, no
// header unless header_bytes says so, in the byte order the recorder wrote. The dimensions come
// from the command line, so the file's size is the only check that they are right: a file that
// is shorter or longer than they say is refused, naming both sizes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

#include "ioct/gpu/offline/spectra_source.hpp"

namespace ioct::gpu::offline {

enum class ByteOrder { little, big };

std::string_view to_string(ByteOrder order) noexcept;
// Throws ConfigError("byte_order", ...) for anything but "little" or "big".
ByteOrder parse_byte_order(std::string_view text);

struct RawSpectraLayout {
  std::uint32_t samples_per_ascan = 0;
  std::uint32_t ascans_per_bscan = 0;
  std::uint32_t bscans = 0;
  ByteOrder byte_order = ByteOrder::little;
  std::uint64_t header_bytes = 0;  // skipped at the start of the file

  // Throws ConfigError: samples in [8, 65536] and even (the chain's FFT needs that), A-scans in
  // [1, 65536], B-scans in [1, 65536], header at most 1 GiB.
  void validate() const;
  std::uint64_t bscan_bytes() const noexcept {
    return std::uint64_t{samples_per_ascan} * ascans_per_bscan * 2;
  }
  // header_bytes + bscans x bscan_bytes().
  std::uint64_t file_bytes() const noexcept { return header_bytes + bscans * bscan_bytes(); }
};

class RawSpectraFile final : public SpectraSource {
 public:
  // Opens the file and checks its size against the layout (validated here). Throws ConfigError
  // for a bad layout and InputFileError for a file that cannot be opened, is not a regular file,
  // or whose size does not match ("truncated: ..." / "... bytes more than ...").
  RawSpectraFile(std::filesystem::path path, const RawSpectraLayout& layout);
  RawSpectraFile(const RawSpectraFile&) = delete;
  RawSpectraFile& operator=(const RawSpectraFile&) = delete;
  ~RawSpectraFile() override;

  const RawSpectraLayout& layout() const noexcept override { return layout_; }
  const std::filesystem::path& path() const noexcept { return path_; }

  // Reads B-scans [first, first + count) into `out` (count x ascans x samples values, in the
  // host's byte order). Throws std::out_of_range for a bad range or size and InputFileError when
  // the read fails (the file shrank since it was opened).
  void read_bscans(std::uint32_t first, std::uint32_t count,
                   std::span<std::uint16_t> out) const override;
  std::string describe() const override { return path_.filename().string(); }

 private:
  std::filesystem::path path_;
  RawSpectraLayout layout_;
  int fd_ = -1;
};

}  // namespace ioct::gpu::offline
