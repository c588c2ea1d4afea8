// A calibration file for lambda -> k resampling: the coefficients c0, c1, ... of the chain's
// calibration polynomial (see ioct/gpu/resampling.hpp), separated by commas, spaces or newlines;
// '#' starts a comment. The chain validates them (finite, the positions strictly increasing and
// inside the sweep) when it is prepared for the file's geometry.
#pragma once

#include <filesystem>
#include <vector>

namespace ioct::gpu::offline {

// Throws InputFileError when the file cannot be read or is empty, ConfigError for text that is
// not a number.
std::vector<double> read_calibration_file(const std::filesystem::path& path);

}  // namespace ioct::gpu::offline
