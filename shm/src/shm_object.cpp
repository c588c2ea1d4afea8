#include "ioct/shm/shm_object.hpp"

#include <grp.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <boost/interprocess/mapped_region.hpp>
#include <boost/interprocess/shared_memory_object.hpp>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

#include "ioct/shm/ring_error.hpp"

namespace bip = boost::interprocess;

namespace ioct::shm {

struct ShmObject::Impl {
  bip::shared_memory_object object;
  bip::mapped_region region;
};

namespace {

std::string errno_text(int err) {
  return std::strerror(err);
}

[[noreturn]] void rethrow(const bip::interprocess_exception& e, const std::string& what,
                          const std::string& name) {
  const std::string where = what + " shared-memory object '" + name + "': ";
  switch (e.get_error_code()) {
    case bip::not_found_error:
      throw RingError(RingErrc::not_found, where + "it does not exist");
    case bip::security_error:
      throw RingError(RingErrc::permission,
                      where + "permission denied (is this user in the ring's group?)");
    case bip::already_exists_error:
      throw RingError(RingErrc::system, where + "it already exists");
    default:
      throw RingError(RingErrc::system,
                      where + e.what() + " (errno " + std::to_string(e.get_native_error()) + ")");
  }
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

}  // namespace

ShmObject::ShmObject(std::unique_ptr<Impl> impl)
    : impl_(std::move(impl)),
      data_(static_cast<std::byte*>(impl_->region.get_address())),
      size_(impl_->region.get_size()),
      name_(impl_->object.get_name()) {}

// A moved-from object owns nothing and says so: data() is null, size() is 0.
ShmObject::ShmObject(ShmObject&& other) noexcept
    : impl_(std::move(other.impl_)),
      data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)),
      name_(std::move(other.name_)),
      locked_(std::exchange(other.locked_, false)) {}

ShmObject& ShmObject::operator=(ShmObject&& other) noexcept {
  if (this != &other) {
    impl_ = std::move(other.impl_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    name_ = std::move(other.name_);
    locked_ = std::exchange(other.locked_, false);
  }
  return *this;
}
ShmObject::~ShmObject() = default;

ShmObject ShmObject::create(const std::string& name, std::uint64_t bytes, unsigned mode,
                            const std::string& group) {
  auto impl = std::make_unique<Impl>();
  try {
    impl->object = bip::shared_memory_object(bip::create_only, name.c_str(), bip::read_write,
                                             bip::permissions(mode));
  } catch (const bip::interprocess_exception& e) {
    rethrow(e, "cannot create", name);
  }
  // An unknown group or a refused chown must not leave a half-made object behind.
  try {
    impl->object.truncate(static_cast<bip::offset_t>(bytes));
    impl->region = bip::mapped_region(impl->object, bip::read_write);
    ShmObject object(std::move(impl));
    object.set_access(mode, group);
    return object;
  } catch (const bip::interprocess_exception& e) {
    bip::shared_memory_object::remove(name.c_str());
    rethrow(e, "cannot size or map", name);
  } catch (...) {
    bip::shared_memory_object::remove(name.c_str());
    throw;
  }
}

void ShmObject::set_access(unsigned mode, const std::string& group) {
  const int fd = impl_->object.get_mapping_handle().handle;
  if (::fchmod(fd, static_cast<mode_t>(mode)) != 0) {
    throw RingError(RingErrc::system, "ring '" + name_ + "': fchmod failed: " + errno_text(errno));
  }
  if (!group.empty() && ::fchown(fd, static_cast<uid_t>(-1), lookup_group(group)) != 0) {
    throw RingError(RingErrc::system, "ring '" + name_ + "': cannot give it to group '" + group +
                                          "': " + errno_text(errno));
  }
}

void ShmObject::set_access(unsigned mode, unsigned group_id) {
  set_access(mode, std::string());
  const int fd = impl_->object.get_mapping_handle().handle;
  if (::fchown(fd, static_cast<uid_t>(-1), static_cast<gid_t>(group_id)) != 0) {
    throw RingError(RingErrc::system, "'" + name_ + "': cannot give it to group id " +
                                          std::to_string(group_id) + ": " + errno_text(errno));
  }
}

unsigned ShmObject::group_id() const {
  struct stat st {};
  if (::fstat(impl_->object.get_mapping_handle().handle, &st) != 0) {
    throw RingError(RingErrc::system, "'" + name_ + "': fstat failed: " + errno_text(errno));
  }
  return static_cast<unsigned>(st.st_gid);
}

ShmObject ShmObject::open(const std::string& name, Access access) {
  auto impl = std::make_unique<Impl>();
  const bip::mode_t mode = access == Access::read_only ? bip::read_only : bip::read_write;
  try {
    impl->object = bip::shared_memory_object(bip::open_only, name.c_str(), mode);
    bip::offset_t size = 0;
    if (!impl->object.get_size(size)) {
      throw RingError(RingErrc::system, "ring '" + name + "': cannot read its size");
    }
    if (size == 0) {
      // A producer creates the object, then sizes it: a reader that looks in between sees 0
      // bytes. Waiting readers retry not_ready; a producer dead at that point left debris,
      // which the next producer removes (RingWriter::create).
      throw RingError(RingErrc::not_ready,
                      "ring '" + name +
                          "': object is 0 bytes: the producer has not sized it yet (or died "
                          "before it did)");
    }
    impl->region = bip::mapped_region(impl->object, mode);
  } catch (const bip::interprocess_exception& e) {
    rethrow(e, "cannot open", name);
  }
  return ShmObject(std::move(impl));
}

bool ShmObject::remove(const std::string& name) noexcept {
  return bip::shared_memory_object::remove(name.c_str());
}

bool ShmObject::exists(const std::string& name) noexcept {
  try {
    bip::shared_memory_object probe(bip::open_only, name.c_str(), bip::read_only);
    return true;
  } catch (const bip::interprocess_exception& e) {
    return e.get_error_code() != bip::not_found_error;
  }
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
