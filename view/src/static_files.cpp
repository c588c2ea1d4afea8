#include "static_files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace ioct::view {
namespace {

bool safe_segment(std::string_view s) {
  if (s.empty() || s.size() > 100 || s.front() == '.') return false;
  for (const char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

}  // namespace

std::string_view content_type_for(const std::filesystem::path& file) noexcept {
  const std::string ext = file.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".json") return "application/json";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".ico") return "image/x-icon";
  if (ext == ".woff2") return "font/woff2";
  return "application/octet-stream";
}

StaticFiles::StaticFiles(std::filesystem::path root) : root_(std::move(root)) {}

std::optional<StaticFile> StaticFiles::find(std::string_view url_path) const {
  const auto query = url_path.find_first_of("?#");
  if (query != std::string_view::npos) url_path = url_path.substr(0, query);
  if (url_path == "/" || url_path.empty()) url_path = "/index.html";
  if (url_path == "/control") url_path = "/control.html";
  if (url_path.front() != '/' || url_path.size() > 512) return std::nullopt;
  std::filesystem::path file = root_;
  std::string_view rest = url_path.substr(1);
  while (!rest.empty()) {
    const auto slash = rest.find('/');
    const std::string_view segment = rest.substr(0, slash);
    if (!safe_segment(segment)) return std::nullopt;
    file /= std::string(segment);
    if (slash == std::string_view::npos) break;
    rest = rest.substr(slash + 1);
  }
  // O_NOFOLLOW | O_NONBLOCK and fstat: no link out of the folder, no FIFO that hangs us.
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
  if (fd < 0) return std::nullopt;
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) ||
      static_cast<std::size_t>(st.st_size) > kMaxFileBytes) {
    ::close(fd);
    return std::nullopt;
  }
  StaticFile out;
  out.body.resize(static_cast<std::size_t>(st.st_size));
  std::size_t done = 0;
  while (done < out.body.size()) {
    const ssize_t n = ::read(fd, out.body.data() + done, out.body.size() - done);
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  if (done != out.body.size()) return std::nullopt;
  out.content_type = std::string(content_type_for(file));
  return out;
}

}  // namespace ioct::view
