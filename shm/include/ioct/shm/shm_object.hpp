// A named shared-memory object and its mapping, with the operations the ring needs around it:
// owner group and mode, prefaulting and locking, removal.
//
// Every open is non-blocking and refuses to follow a link, and the object is checked with fstat
// (regular file, owner, mode) before it is mapped: a FIFO, a device or another user's file under
// the name can neither block nor crash the process that opens it. Plain POSIX calls, not
// Boost.Interprocess, because Boost can neither open non-blocking nor check before it maps.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace ioct::shm {

// read_only: a reader's mapping; the object must be writable by its owner only.
// read_write: one of ours; the object must belong to this process's user.
enum class Access { read_only, read_write };

// Where the object called `name` lives: a plain name ("ioct-ring") is a POSIX shared-memory name,
// the file /dev/shm/NAME; an absolute path ("/dev/shm/ioct/ring") is a file at that path, in a
// directory that only the service users may write (shm/README.md, "Where the objects live").
std::string object_path(const std::string& name);

// Empty when `name` is a valid object name: 1 to 200 characters, either without '/' (an object in
// /dev/shm) or an absolute path to a file in a directory, without '.' parts; otherwise what is
// wrong with it, for the caller's message.
std::string object_name_problem(const std::string& name);

// Bytes an object called `name` could have: what the file system holding it has free, plus what
// an object already under the name (which a new ring would replace) holds. nullopt when unknown.
std::optional<std::uint64_t> room_for_object(const std::string& name);

// "a FIFO owned by user nobody (uid 65534), mode 0644": what is at `path`, for messages.
std::string describe_file(const std::string& path);

class ShmObject {
 public:
  // Creates a new object (fails if the name exists: RingError(squatted) naming what is there and
  // who owns it) of `bytes`, mode `mode` regardless of the umask, owned by `group` when not empty.
  // The bytes are allocated (posix_fallocate), so a full file system is RingError(no_space)
  // naming the bytes needed and free, never a SIGBUS later. Throws RingError.
  static ShmObject create(const std::string& name, std::uint64_t bytes, unsigned mode,
                          const std::string& group);
  // Opens an existing object and maps all of it. Throws RingError(not_found | permission |
  // squatted (not a regular file, another user's, writable by others) | not_ready | system).
  static ShmObject open(const std::string& name, Access access);
  // Removes the name; true if it existed. Mappings already made stay valid.
  static bool remove(const std::string& name) noexcept;
  static bool exists(const std::string& name) noexcept;

  ShmObject(ShmObject&&) noexcept;
  ShmObject& operator=(ShmObject&&) noexcept;
  ~ShmObject();

  std::byte* data() const noexcept { return data_; }
  std::uint64_t size() const noexcept { return size_; }
  const std::string& name() const noexcept { return name_; }

  // Touches every page so no later access faults, then mlock()s the mapping. Returns false when
  // locking is refused (RLIMIT_MEMLOCK); the pages are touched either way.
  bool prefault_and_lock() noexcept;

  // Sets the mode regardless of the umask and, when `group` is not empty, the owning group.
  // Throws RingError(bad_config) for an unknown group, RingError(system) when refused.
  void set_access(unsigned mode, const std::string& group);
  // The same with a numeric group id (e.g. another object's, see group_id()).
  void set_access(unsigned mode, unsigned group_id);
  // The object's owning group id.
  unsigned group_id() const;

 private:
  ShmObject(int fd, std::byte* data, std::uint64_t size, std::string name);
  void release() noexcept;  // unmaps and closes; the object then owns nothing
  int fd_ = -1;
  std::byte* data_ = nullptr;
  std::uint64_t size_ = 0;
  std::string name_;
  bool locked_ = false;
};

// This process's identity as stored in a header: pid plus start time (clock ticks since boot),
// so a pid the kernel reused for another process is not mistaken for the original one.
struct ProcessIdentity {
  std::uint64_t pid = 0;
  std::uint64_t start_ticks = 0;
  static ProcessIdentity self();
  bool alive() const;  // the same process is still running
};

}  // namespace ioct::shm
