#include "ioct/test_support/temp_path.hpp"

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <stdexcept>

namespace ioct::test_support {
namespace {

std::atomic<unsigned> g_count{0};

}  // namespace

TempPath::TempPath(std::string_view tag, std::string_view suffix)
    : path_(std::filesystem::temp_directory_path() /
            ("ioct-" + std::string(tag) + "-" + std::to_string(::getpid()) + "-" +
             std::to_string(g_count++) + std::string(suffix))) {
  std::filesystem::remove_all(path_);
}

TempPath TempPath::with_text(std::string_view tag, std::string_view suffix, std::string_view text) {
  TempPath temp(tag, suffix);
  std::ofstream out(temp.path_, std::ios::binary);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out.flush()) throw std::runtime_error("cannot write " + temp.str());
  return temp;
}

TempPath::~TempPath() {
  std::error_code ignored;
  if (!path_.empty()) std::filesystem::remove_all(path_, ignored);
}

TempPath::TempPath(TempPath&& other) noexcept : path_(std::move(other.path_)) {
  other.path_.clear();
}

}  // namespace ioct::test_support
