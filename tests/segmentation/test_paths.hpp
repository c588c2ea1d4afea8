// Where the tests find the shared test data and the ioct-segment executable: the build's paths,
// unless the environment says otherwise (IOCT_TEST_DATA_DIR, IOCT_SEGMENT_EXE), as on a machine
// that runs binaries built elsewhere.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

namespace ioct::seg_test {

inline std::filesystem::path test_data_dir() {
  const char* dir = std::getenv("IOCT_TEST_DATA_DIR");
  return dir != nullptr && *dir != '\0' ? std::filesystem::path(dir)
                                        : std::filesystem::path(IOCT_TEST_DATA_DIR);
}

inline std::filesystem::path spectralis_file() {
  return test_data_dir() / "spectralis_circle_valid.vol";
}

inline std::string segment_executable() {
  const char* exe = std::getenv("IOCT_SEGMENT_EXE");
  return exe != nullptr && *exe != '\0' ? std::string(exe) : std::string(IOCT_SEGMENT_EXE);
}

}  // namespace ioct::seg_test
