#include "ioct/shm/shm_object.hpp"

#include <fcntl.h>
#include <grp.h>
#include <pwd.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

#include "ioct/shm/ring_error.hpp"

namespace ioct::shm {

namespace {

// O_NONBLOCK: opening a FIFO must not wait for a writer. O_NOFOLLOW: a link is never followed.
constexpr int kOpenFlags = O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC;

std::string errno_text(int err) {
  return std::strerror(err);
}

std::string octal(unsigned mode) {
  char text[16];
  std::snprintf(text, sizeof text, "0%o", mode & 07777u);
  return text;
}

std::string user_name(uid_t uid) {
  std::vector<char> buffer(16384);
  struct passwd entry {};
  struct passwd* found = nullptr;
  if (::getpwuid_r(uid, &entry, buffer.data(), buffer.size(), &found) == 0 && found != nullptr) {
    return std::string("user ") + found->pw_name + " (uid " + std::to_string(uid) + ")";
  }
  return "uid " + std::to_string(uid);
}

std::string describe_stat(const struct stat& st) {
  const char* kind = S_ISREG(st.st_mode)    ? "a regular file"
                     : S_ISFIFO(st.st_mode) ? "a FIFO"
                     : S_ISLNK(st.st_mode)  ? "a symbolic link"
                     : S_ISDIR(st.st_mode)  ? "a directory"
                     : S_ISSOCK(st.st_mode) ? "a socket"
                     : S_ISCHR(st.st_mode)  ? "a character device"
                     : S_ISBLK(st.st_mode)  ? "a block device"
                                            : "an unknown kind of file";
  return std::string(kind) + " owned by " + user_name(st.st_uid) + ", mode " + octal(st.st_mode);
}

gid_t lookup_group(const std::string& group) {
  std::vector<char> buffer(16384);
  struct group entry {};
  struct group* found = nullptr;
  const int rc = ::getgrnam_r(group.c_str(), &entry, buffer.data(), buffer.size(), &found);
  if (rc != 0 || found == nullptr) {
    throw RingError(RingErrc::bad_config, "ring: group '" + group + "' does not exist" +
                                              (rc != 0 ? " (" + errno_text(rc) + ")" : ""));
  }
  return found->gr_gid;
}

std::string directory_of(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == 0 ? "/" : path.substr(0, slash);
}

// Allocates the object's bytes now: on tmpfs a sparse object that outgrows the free space kills
// its writer with SIGBUS at the first page that cannot be had.
void allocate(int fd, const std::string& path, std::uint64_t bytes) {
  if (bytes > static_cast<std::uint64_t>(std::numeric_limits<off_t>::max())) {
    throw RingError(RingErrc::bad_config, "'" + path + "': " + std::to_string(bytes) +
                                              " bytes is more than a file can hold");
  }
  const int rc = ::posix_fallocate(fd, 0, static_cast<off_t>(bytes));
  if (rc == 0) return;
  if (rc == ENOSPC || rc == EFBIG) {
    struct statvfs fs {};
    const std::string dir = directory_of(path);
    const std::string free_text =
        ::statvfs(dir.c_str(), &fs) == 0
            ? std::to_string(static_cast<std::uint64_t>(fs.f_bavail) * fs.f_frsize) + " bytes free"
            : "free space unknown";
    throw RingError(RingErrc::no_space, "'" + path + "': needs " + std::to_string(bytes) +
                                            " bytes, " + dir + " has " + free_text +
                                            " (make the ring smaller: fewer slots or a smaller "
                                            "geometry, or give the file system more room)");
  }
  throw RingError(RingErrc::system, "'" + path + "': cannot allocate " + std::to_string(bytes) +
                                        " bytes: " + errno_text(rc));
}

// Checks an opened object before it is mapped.
void check_opened(int fd, const std::string& path, Access access, struct stat& st) {
  if (::fstat(fd, &st) != 0) {
    throw RingError(RingErrc::system, "'" + path + "': fstat failed: " + errno_text(errno));
  }
  if (!S_ISREG(st.st_mode)) {
    throw RingError(RingErrc::squatted, "'" + path + "' is " + describe_stat(st) +
                                            ", not a shared-memory object; not using it");
  }
  if (access == Access::read_write && st.st_uid != ::geteuid()) {
    throw RingError(RingErrc::squatted, "'" + path + "' is " + describe_stat(st) +
                                            ", not this process's user's; not using it");
  }
  if (access == Access::read_only && (st.st_mode & 0022u) != 0) {
    // Whoever may write it may truncate it, and a truncated mapping is a SIGBUS.
    throw RingError(RingErrc::squatted,
                    "'" + path + "' is " + describe_stat(st) +
                        ": writable by others than its owner, so it could be truncated under "
                        "a mapping; not using it");
  }
}

}  // namespace

std::string object_name_problem(const std::string& name) {
  const bool is_path = !name.empty() && name.front() == '/';
  const bool plain_ok = !is_path && name.find('/') == std::string::npos;
  // A path names a file in a directory of its own (not in "/"), without "." or ".." parts.
  const bool path_ok = is_path && name.rfind('/') > 0 && name.back() != '/' &&
                       name.find("/.") == std::string::npos && name.find("//") == std::string::npos;
  if (!name.empty() && name.size() <= 200 && (plain_ok || path_ok)) return {};
  return "must be 1 to 200 characters: a name without '/' (an object in /dev/shm) or an absolute "
         "path to a file in a directory, without '.' parts (e.g. /dev/shm/ioct/ring)";
}

std::string object_path(const std::string& name) {
  if (!name.empty() && name.front() == '/') return name;
  return "/dev/shm/" + name;
}

std::optional<std::uint64_t> room_for_object(const std::string& name) {
  const std::string path = object_path(name);
  struct statvfs fs {};
  if (::statvfs(directory_of(path).c_str(), &fs) != 0) return std::nullopt;
  std::uint64_t room = static_cast<std::uint64_t>(fs.f_bavail) * fs.f_frsize;
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) {
    room += static_cast<std::uint64_t>(st.st_blocks) * 512u;
  }
  return room;
}

std::string describe_file(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return "nothing (" + errno_text(errno) + ")";
  return describe_stat(st);
}

ShmObject::ShmObject(int fd, std::byte* data, std::uint64_t size, std::string name)
    : fd_(fd), data_(data), size_(size), name_(std::move(name)) {}

// A moved-from object owns nothing and says so: data() is null, size() is 0.
ShmObject::ShmObject(ShmObject&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)),
      name_(std::move(other.name_)),
      locked_(std::exchange(other.locked_, false)) {}

ShmObject& ShmObject::operator=(ShmObject&& other) noexcept {
  if (this != &other) {
    release();
    fd_ = std::exchange(other.fd_, -1);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    name_ = std::move(other.name_);
    locked_ = std::exchange(other.locked_, false);
  }
  return *this;
}

ShmObject::~ShmObject() {
  release();
}

void ShmObject::release() noexcept {
  if (data_ != nullptr) ::munmap(data_, size_);
  if (fd_ >= 0) ::close(fd_);
  data_ = nullptr;
  size_ = 0;
  fd_ = -1;
  locked_ = false;
}

ShmObject ShmObject::create(const std::string& name, std::uint64_t bytes, unsigned mode,
                            const std::string& group) {
  const std::string path = object_path(name);
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | kOpenFlags,
                        static_cast<mode_t>(mode & 0600u));
  if (fd < 0) {
    const int err = errno;
    if (err == EEXIST) {
      throw RingError(RingErrc::squatted,
                      "cannot create '" + path + "': the name is taken by " + describe_file(path));
    }
    throw RingError(err == EACCES ? RingErrc::permission : RingErrc::system,
                    "cannot create '" + path + "': " + errno_text(err));
  }
  // Nothing half-made stays behind: a failure below removes the name again (and `object`, which
  // owns the descriptor from here, closes it).
  ShmObject object(fd, nullptr, 0, name);
  try {
    // Mode and group before the allocation, which can take long for a large ring: the name never
    // shows other access than the one asked for once anyone could look at its contents.
    object.set_access(mode, group);
    allocate(fd, path, bytes);
    void* data = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (data == MAP_FAILED) {
      throw RingError(RingErrc::system, "cannot map '" + path + "' (" + std::to_string(bytes) +
                                            " bytes): " + errno_text(errno));
    }
    object.data_ = static_cast<std::byte*>(data);
    object.size_ = bytes;
    return object;
  } catch (...) {
    ::unlink(path.c_str());
    throw;
  }
}

void ShmObject::set_access(unsigned mode, const std::string& group) {
  if (::fchmod(fd_, static_cast<mode_t>(mode)) != 0) {
    throw RingError(RingErrc::system, "'" + name_ + "': fchmod failed: " + errno_text(errno));
  }
  if (!group.empty() && ::fchown(fd_, static_cast<uid_t>(-1), lookup_group(group)) != 0) {
    throw RingError(RingErrc::system, "'" + name_ + "': cannot give it to group '" + group +
                                          "': " + errno_text(errno));
  }
}

void ShmObject::set_access(unsigned mode, unsigned group_id) {
  set_access(mode, std::string());
  if (::fchown(fd_, static_cast<uid_t>(-1), static_cast<gid_t>(group_id)) != 0) {
    throw RingError(RingErrc::system, "'" + name_ + "': cannot give it to group id " +
                                          std::to_string(group_id) + ": " + errno_text(errno));
  }
}

unsigned ShmObject::group_id() const {
  struct stat st {};
  if (::fstat(fd_, &st) != 0) {
    throw RingError(RingErrc::system, "'" + name_ + "': fstat failed: " + errno_text(errno));
  }
  return static_cast<unsigned>(st.st_gid);
}

ShmObject ShmObject::open(const std::string& name, Access access) {
  const std::string path = object_path(name);
  const int fd =
      ::open(path.c_str(), (access == Access::read_only ? O_RDONLY : O_RDWR) | kOpenFlags);
  if (fd < 0) {
    const int err = errno;
    switch (err) {
      case ENOENT:
        throw RingError(RingErrc::not_found, "cannot open '" + path + "': it does not exist");
      case EACCES:
      case EPERM:
        throw RingError(RingErrc::permission, "cannot open '" + path +
                                                  "': permission denied (is this user in the "
                                                  "ring's group?)");
      case ELOOP:
      case ENXIO:
        throw RingError(RingErrc::squatted, "cannot open '" + path + "': it is " +
                                                describe_file(path) + "; not using it");
      default:
        throw RingError(RingErrc::system, "cannot open '" + path + "': " + errno_text(err));
    }
  }
  try {
    struct stat st {};
    check_opened(fd, path, access, st);
    if (st.st_size == 0) {
      // A producer creates the object, then sizes it: a reader that looks in between sees 0
      // bytes. Waiting readers retry not_ready; a producer dead at that point left debris,
      // which the next producer removes (RingWriter::create).
      throw RingError(RingErrc::not_ready,
                      "'" + path +
                          "': object is 0 bytes: the producer has not sized it yet (or died "
                          "before it did)");
    }
    const auto bytes = static_cast<std::uint64_t>(st.st_size);
    const int prot = access == Access::read_only ? PROT_READ : PROT_READ | PROT_WRITE;
    void* data = ::mmap(nullptr, bytes, prot, MAP_SHARED, fd, 0);
    if (data == MAP_FAILED) {
      throw RingError(RingErrc::system, "cannot map '" + path + "': " + errno_text(errno));
    }
    return ShmObject(fd, static_cast<std::byte*>(data), bytes, name);
  } catch (...) {
    ::close(fd);
    throw;
  }
}

bool ShmObject::remove(const std::string& name) noexcept {
  return ::unlink(object_path(name).c_str()) == 0;
}

bool ShmObject::exists(const std::string& name) noexcept {
  struct stat st {};
  return ::lstat(object_path(name).c_str(), &st) == 0;
}

bool ShmObject::prefault_and_lock() noexcept {
  const long page = ::sysconf(_SC_PAGESIZE);
  for (std::uint64_t off = 0; off < size_; off += static_cast<std::uint64_t>(page)) {
    // A write, not a read: a read maps the shared zero page and the first write still faults.
    reinterpret_cast<volatile std::byte*>(data_)[off] = data_[off];
  }
  locked_ = ::mlock(data_, size_) == 0;
  return locked_;
}

namespace {

struct ProcStat {
  char state = '?';
  std::uint64_t start_ticks = 0;
};

// Fields 3 (state) and 22 (starttime) of /proc/PID/stat, counted after the command name, which
// may itself contain spaces and parentheses.
std::optional<ProcStat> read_proc_stat(const std::string& path) {
  std::ifstream file(path);
  if (!file) return std::nullopt;
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const auto close = text.rfind(')');
  if (close == std::string::npos || close + 2 > text.size()) return std::nullopt;
  std::istringstream fields(text.substr(close + 2));
  ProcStat stat;
  std::string field;
  for (int i = 3; i <= 22 && fields >> field; ++i) {
    if (i == 3) stat.state = field.empty() ? '?' : field[0];
    if (i == 22) {
      stat.start_ticks = std::strtoull(field.c_str(), nullptr, 10);
      return stat;
    }
  }
  return std::nullopt;
}

}  // namespace

ProcessIdentity ProcessIdentity::self() {
  ProcessIdentity id;
  id.pid = static_cast<std::uint64_t>(::getpid());
  if (const auto stat = read_proc_stat("/proc/self/stat")) id.start_ticks = stat->start_ticks;
  return id;
}

bool ProcessIdentity::alive() const {
  if (pid == 0) return false;
  const auto stat = read_proc_stat("/proc/" + std::to_string(pid) + "/stat");
  return stat && stat->state != 'Z' && stat->start_ticks == start_ticks;
}

}  // namespace ioct::shm
