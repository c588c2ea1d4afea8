#include "ioct/gpu/offline/raw_spectra_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <bit>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"

namespace ioct::gpu::offline {

std::string_view to_string(ByteOrder order) noexcept {
  return order == ByteOrder::little ? "little" : "big";
}

ByteOrder parse_byte_order(std::string_view text) {
  if (text == "little") return ByteOrder::little;
  if (text == "big") return ByteOrder::big;
  throw ConfigError("byte_order", "'" + std::string(text) + "'", "must be little or big");
}

void RawSpectraLayout::validate() const {
  require_integer_in_range("samples_per_ascan", samples_per_ascan, 8, 65536);
  if (samples_per_ascan % 2 != 0) {
    throw ConfigError("samples_per_ascan", format_value(std::uint64_t{samples_per_ascan}),
                      "must be even (the FFT gives samples / 2 depth pixels)");
  }
  require_integer_in_range("ascans_per_bscan", ascans_per_bscan, 1, 65536);
  require_integer_in_range("bscans", bscans, 1, 65536);
  require_integer_in_range("header_bytes", header_bytes, 0, std::uint64_t{1} << 30);
}

namespace {

std::string dimensions_text(const RawSpectraLayout& layout) {
  return std::to_string(layout.bscans) + " B-scans x " + std::to_string(layout.ascans_per_bscan) +
         " A-scans x " + std::to_string(layout.samples_per_ascan) + " samples of 2 bytes" +
         (layout.header_bytes > 0
              ? " after a header of " + std::to_string(layout.header_bytes) + " bytes"
              : "");
}

}  // namespace

RawSpectraFile::RawSpectraFile(std::filesystem::path path, const RawSpectraLayout& layout)
    : path_(std::move(path)), layout_(layout) {
  layout_.validate();
  // Non-blocking: a FIFO is refused below instead of waiting for a writer.
  fd_ = ::open(path_.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) throw InputFileError(path_, std::string("cannot open: ") + std::strerror(errno));
  struct stat info {};
  if (::fstat(fd_, &info) != 0 || !S_ISREG(info.st_mode)) {
    ::close(fd_);
    throw InputFileError(path_, "not a regular file (a FIFO or a device has no size to check)");
  }
  const auto size = static_cast<std::uint64_t>(info.st_size);
  const std::uint64_t expected = layout_.file_bytes();
  if (size != expected) {
    ::close(fd_);
    const std::string sizes = std::to_string(size) + " bytes, but " + dimensions_text(layout_) +
                              " need " + std::to_string(expected);
    if (size < expected) {
      throw InputFileError(path_, "truncated or wrong dimensions: the file has " + sizes);
    }
    throw InputFileError(
        path_, "larger than its dimensions say (wrong dimensions?): the file has " + sizes + " (" +
                   std::to_string(size - expected) + " more)");
  }
}

RawSpectraFile::~RawSpectraFile() {
  if (fd_ >= 0) ::close(fd_);
}

void RawSpectraFile::read_bscans(std::uint32_t first, std::uint32_t count,
                                 std::span<std::uint16_t> out) const {
  const std::uint64_t values =
      std::uint64_t{count} * layout_.ascans_per_bscan * layout_.samples_per_ascan;
  if (first > layout_.bscans || count > layout_.bscans - first || out.size() < values) {
    throw std::out_of_range("read_bscans: B-scans [" + std::to_string(first) + ", " +
                            std::to_string(std::uint64_t{first} + count) +
                            ") or the buffer do not fit the file's " +
                            std::to_string(layout_.bscans) + " B-scans");
  }
  auto* bytes = reinterpret_cast<char*>(out.data());
  std::uint64_t remaining = values * 2;
  auto offset = static_cast<off_t>(layout_.header_bytes + first * layout_.bscan_bytes());
  while (remaining > 0) {
    const ssize_t got = ::pread(fd_, bytes, remaining, offset);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) {
      throw InputFileError(path_, got == 0 ? "ended early while reading (did it shrink?)"
                                           : std::string("read failed: ") + std::strerror(errno));
    }
    bytes += got;
    offset += got;
    remaining -= static_cast<std::uint64_t>(got);
  }
  const bool swap =
      (layout_.byte_order == ByteOrder::big) == (std::endian::native == std::endian::little);
  if (swap) {
    for (std::uint64_t i = 0; i < values; ++i) {
      out[i] = static_cast<std::uint16_t>((out[i] >> 8) | (out[i] << 8));
    }
  }
}

}  // namespace ioct::gpu::offline
