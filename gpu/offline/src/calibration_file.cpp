#include "ioct/gpu/offline/calibration_file.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/resampling.hpp"

namespace ioct::gpu::offline {

std::vector<double> read_calibration_file(const std::filesystem::path& path) {
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
  return parse_coefficients(joined);  // ConfigError names the bad value
}

}  // namespace ioct::gpu::offline
