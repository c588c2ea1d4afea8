// The pages: files under the www folder, found by URL path without ever leaving the folder.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace ioct::view {

struct StaticFile {
  std::string body;
  std::string content_type;
};

class StaticFiles {
 public:
  explicit StaticFiles(std::filesystem::path root);

  // "/" is index.html and "/control" control.html; other paths name files under the root. Only
  // [A-Za-z0-9._-] path segments that do not start with '.', regular files up to 8 MiB; nullopt
  // for anything else (the caller answers 404).
  std::optional<StaticFile> find(std::string_view url_path) const;
  const std::filesystem::path& root() const noexcept { return root_; }

  static constexpr std::size_t kMaxFileBytes = 8u << 20;

 private:
  std::filesystem::path root_;
};

std::string_view content_type_for(const std::filesystem::path& file) noexcept;

}  // namespace ioct::view
