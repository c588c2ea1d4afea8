// A named POSIX shared-memory object and its mapping (Boost.Interprocess underneath), with the
// operations the ring needs around it: owner group and mode, prefaulting and locking, removal.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace ioct::shm {

enum class Access { read_only, read_write };

class ShmObject {
 public:
  // Creates a new object (fails if the name exists) of `bytes`, mode `mode` regardless of the
  // umask, owned by `group` when not empty. Throws RingError.
  static ShmObject create(const std::string& name, std::uint64_t bytes, unsigned mode,
                          const std::string& group);
  // Opens an existing object and maps all of it. Throws RingError(not_found | permission | system).
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
  struct Impl;
  explicit ShmObject(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
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
