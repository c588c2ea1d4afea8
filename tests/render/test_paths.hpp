// Where the tests find the shared test data and the ioct-render executable: the build's paths,
// unless the environment says otherwise (IOCT_TEST_DATA_DIR, IOCT_RENDER_EXE), as on a machine
// that runs binaries built elsewhere.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

namespace ioct::render_test {

inline std::filesystem::path test_data_dir() {
  const char* dir = std::getenv("IOCT_TEST_DATA_DIR");
  return dir != nullptr && *dir != '\0' ? std::filesystem::path(dir)
                                        : std::filesystem::path(IOCT_TEST_DATA_DIR);
}

inline std::string render_executable() {
  const char* exe = std::getenv("IOCT_RENDER_EXE");
  return exe != nullptr && *exe != '\0' ? std::string(exe) : std::string(IOCT_RENDER_EXE);
}

}  // namespace ioct::render_test
