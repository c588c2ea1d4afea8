// A path in the temporary directory that no other test or process uses (tag, pid and a count),
// removed with anything under it when the object goes. with_text() writes a file there first.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace ioct::test_support {

class TempPath {
 public:
  // "<tmp>/ioct-<tag>-<pid>-<n><suffix>", nothing there yet.
  explicit TempPath(std::string_view tag, std::string_view suffix = "");
  // The same, holding `text` as a file.
  static TempPath with_text(std::string_view tag, std::string_view suffix, std::string_view text);
  ~TempPath();
  TempPath(TempPath&& other) noexcept;
  TempPath(const TempPath&) = delete;
  TempPath& operator=(const TempPath&) = delete;
  TempPath& operator=(TempPath&&) = delete;

  const std::filesystem::path& path() const noexcept { return path_; }
  std::string str() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace ioct::test_support
