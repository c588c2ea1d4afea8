#include "ioct/gpu/offline/calibration_file.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/processing/resampling.hpp"

namespace ioct::gpu::offline {

std::vector<double> read_calibration_file(const std::filesystem::path& path) {
  // A few coefficients: anything larger than this is not a calibration file.
  constexpr std::uint64_t kMaxCalibrationBytes = 64 * 1024;
  const std::uint64_t bytes = checked_input_size(path);
  if (bytes > kMaxCalibrationBytes) {
    throw InputFileError(path, std::to_string(bytes) + " bytes: a calibration file has at most " +
                                   std::to_string(kMaxCalibrationBytes));
  }
  std::ifstream in(path);
  if (!in) throw InputFileError(path, std::string("cannot open: ") + std::strerror(errno));
  std::string joined;
  for (std::string line; std::getline(in, line);) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream words(line);
    for (std::string word; words >> word;) {
      // Commas and whitespace both separate coefficients.
      for (char& c : word) {
        if (c == ',') c = ' ';
      }
      std::istringstream parts(word);
      for (std::string part; parts >> part;) joined += (joined.empty() ? "" : ",") + part;
    }
  }
  if (joined.empty()) throw InputFileError(path, "holds no calibration coefficients");
  try {
    return parse_coefficients(joined);
  } catch (const ConfigError& e) {
    throw InputFileError(path, e.what());  // the value's fault, in the file's name
  }
}

}  // namespace ioct::gpu::offline
