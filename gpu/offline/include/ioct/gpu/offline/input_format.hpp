// Which file format an input is, told by its first bytes (its magic), never by its extension:
// a Bioptigen export is ".OCT", ".oct" or renamed, and other vendors use ".oct" too.
#pragma once

#include <filesystem>
#include <string_view>

namespace ioct::gpu::offline {

enum class InputFormat { heidelberg_vol, bioptigen_oct, nrrd, unknown };

// Reads at most the first 8 bytes of `path` (a regular file: checked first, so a FIFO cannot
// block). Throws InputFileError when it cannot be read.
InputFormat detect_input_format(const std::filesystem::path& path);

// "Heidelberg .vol (HSF-OCT-)", "Bioptigen .OCT (magic 0x0C7DA7A5)", "NRRD", "unknown".
std::string_view input_format_name(InputFormat format) noexcept;

}  // namespace ioct::gpu::offline
