#include "ioct/gpu/offline/input_format.hpp"

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>

#include "ioct/gpu/offline/bioptigen_oct.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"

namespace ioct::gpu::offline {

InputFormat detect_input_format(const std::filesystem::path& path) {
  const std::uint64_t size = checked_input_size(path);
  std::uint8_t head[8] = {};
  const std::size_t n = size < sizeof head ? static_cast<std::size_t>(size) : sizeof head;
  std::ifstream in(path, std::ios::binary);
  if (!in || !in.read(reinterpret_cast<char*>(head), static_cast<std::streamsize>(n))) {
    throw InputFileError(path, std::string("cannot read its first bytes: ") + std::strerror(errno));
  }
  if (n >= 8 && std::memcmp(head, "HSF-OCT-", 8) == 0) return InputFormat::heidelberg_vol;
  if (has_bioptigen_magic(head, n)) return InputFormat::bioptigen_oct;
  if (n >= 4 && std::memcmp(head, "NRRD", 4) == 0) return InputFormat::nrrd;
  return InputFormat::unknown;
}

std::string_view input_format_name(InputFormat format) noexcept {
  switch (format) {
    case InputFormat::heidelberg_vol:
      return "Heidelberg .vol (HSF-OCT-)";
    case InputFormat::bioptigen_oct:
      return "Bioptigen .OCT (magic 0x0C7DA7A5)";
    case InputFormat::nrrd:
      return "NRRD";
    case InputFormat::unknown:
      break;
  }
  return "unknown";
}

}  // namespace ioct::gpu::offline
