// Issue 17 (F1, F3, F10): nothing another local user puts into the shared-memory namespace can
// block or crash the ring's processes. A FIFO where a reader's status object or the ring itself
// is expected is skipped or refused at once, never waited on; a name taken first by someone else
// is reported with its owner; a ring larger than the room where it lives is a RingError naming
// both sizes, not a SIGBUS.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "ioct/shm/reader_status.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/shm/shm_object.hpp"
#include "ioct/test_support/bounded_child.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

using test_support::ScopedShmName;

using test_support::ChildLimits;
using test_support::ChildOutcome;
using test_support::run_in_child;

std::string expect_ring_error(const std::function<void()>& action, shm::RingErrc code) {
  try {
    action();
  } catch (const shm::RingError& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no RingError";
  return {};
}

// F1: the producer's housekeeping lists its readers; a FIFO among their status objects (any
// local user may make one in /dev/shm) must be skipped without waiting for a writer.
TEST(RingNamespace, ReaderScanSkipsAFifoWithoutBlocking) {
  const ScopedShmName name("fifo-status");
  const shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str()));
  const shm::RingReader reader = shm::RingReader::attach(name.str());
  const std::string fifo = name.str() + ".reader.999.0";
  ASSERT_EQ(::mkfifo(("/dev/shm/" + fifo).c_str(), 0644), 0);

  const ChildOutcome outcome = run_in_child(
      [&] {
        std::vector<std::string> skipped;
        const auto reports = shm::scan_reader_status(name.str(), &skipped);
        (void)writer.reap_dead_readers();
        return reports.size() == 1 && skipped == std::vector<std::string>{fifo};
      },
      ChildLimits{});
  EXPECT_EQ(outcome, ChildOutcome::passed)
      << (outcome == ChildOutcome::hung ? "the scan blocked on the FIFO" : "wrong reports");
}

// F1: a status object whose owner shortens it while the producer reads is read, not mapped, so
// it cannot crash the producer with SIGBUS; a short one is skipped.
TEST(RingNamespace, ReaderScanSkipsATruncatedStatusObject) {
  const ScopedShmName name("short-status");
  const shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str()));
  const shm::RingReader reader = shm::RingReader::attach(name.str());
  ASSERT_EQ(::truncate(("/dev/shm/" + *reader.status_object_name()).c_str(), 16), 0);
  std::vector<std::string> skipped;
  EXPECT_TRUE(shm::scan_reader_status(name.str(), &skipped).empty());
  EXPECT_EQ(skipped.size(), 1u);
}

// F1: ioct-gpu attaching to a ring name that is a FIFO gets an error at once.
TEST(RingNamespace, AttachingToAFifoFailsAtOnce) {
  const ScopedShmName name("fifo-ring");
  ASSERT_EQ(::mkfifo(("/dev/shm/" + name.str()).c_str(), 0644), 0);
  const ChildOutcome outcome = run_in_child(
      [&] {
        try {
          (void)shm::RingReader::attach(name.str());
        } catch (const shm::RingError& e) {
          return e.code() == shm::RingErrc::squatted &&
                 std::string(e.what()).find("a FIFO") != std::string::npos;
        }
        return false;
      },
      ChildLimits{});
  EXPECT_EQ(outcome, ChildOutcome::passed)
      << (outcome == ChildOutcome::hung ? "attach blocked on the FIFO" : "not a squatted error");
}

// F10: a name taken first is reported with what is there and who owns it, and left alone.
TEST(RingNamespace, SquattedNameIsReportedWithItsOwner) {
  const ScopedShmName name("squat-fifo");
  const std::string path = "/dev/shm/" + name.str();
  ASSERT_EQ(::mkfifo(path.c_str(), 0666), 0);
  const std::string message =
      expect_ring_error([&] { (void)shm::RingWriter::create(small_test_config(name.str())); },
                        shm::RingErrc::squatted);
  EXPECT_NE(message.find("a FIFO owned by"), std::string::npos) << message;
  EXPECT_NE(message.find("uid " + std::to_string(::geteuid())), std::string::npos) << message;
  struct stat st {};
  EXPECT_EQ(::lstat(path.c_str(), &st), 0) << "what is not ours is left alone";
}

TEST(RingNamespace, AnotherUsersFileUnderTheNameIsReportedWithItsOwner) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to make a file owned by another user";
  const ScopedShmName name("squat-file");
  const std::string path = "/dev/shm/" + name.str();
  {
    const int fd = ::open(path.c_str(), O_CREAT | O_EXCL | O_WRONLY, 0600);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::fchown(fd, 65534, 65534), 0);
    ::close(fd);
  }
  const std::string message =
      expect_ring_error([&] { (void)shm::RingWriter::create(small_test_config(name.str())); },
                        shm::RingErrc::squatted);
  EXPECT_NE(message.find("uid 65534"), std::string::npos) << message;
  EXPECT_NE(message.find("not this process's user's"), std::string::npos) << message;
}

// F10: the installed service names its ring by a path in a directory only the service users may
// write (shm/README.md); the object is a plain file there, status objects beside it.
TEST(RingNamespace, RingAndStatusObjectsLiveInTheRingsDirectory) {
  const std::string dir = "/dev/shm/ioct-test-dir-" + std::to_string(::getpid());
  ASSERT_TRUE(std::filesystem::create_directory(dir));
  {
    const std::string ring = dir + "/ring";
    const shm::RingWriter writer = shm::RingWriter::create(small_test_config(ring));
    const shm::RingReader reader = shm::RingReader::attach(ring);
    EXPECT_TRUE(std::filesystem::is_regular_file(ring));
    ASSERT_TRUE(reader.status_object_name().has_value());
    EXPECT_EQ(reader.status_object_name()->rfind(dir + "/ring.reader.", 0), 0u)
        << *reader.status_object_name();
    const auto readers = writer.readers();
    ASSERT_EQ(readers.size(), 1u);
    EXPECT_EQ(readers[0].object_name, *reader.status_object_name());
  }
  std::filesystem::remove_all(dir);
}

// F2: readers refuse a ring others than its owner may write (they could truncate it).
TEST(RingNamespace, ReaderRefusesARingOthersMayWrite) {
  const ScopedShmName name("group-writable");
  const shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str()));
  ASSERT_EQ(::chmod(("/dev/shm/" + name.str()).c_str(), 0660), 0);
  const std::string message = expect_ring_error([&] { (void)shm::RingReader::attach(name.str()); },
                                                shm::RingErrc::squatted);
  EXPECT_NE(message.find("writable by others"), std::string::npos) << message;
}

// A tmpfs of `bytes` mounted on a fresh directory for the test's lifetime.
class SmallTmpfs {
 public:
  explicit SmallTmpfs(std::size_t bytes) {
    char pattern[] = "/tmp/ioct-small-shm-XXXXXX";
    if (::mkdtemp(pattern) == nullptr) return;
    dir_ = pattern;
    const std::string options = "size=" + std::to_string(bytes) + ",mode=0700";
    if (::mount("tmpfs", dir_.c_str(), "tmpfs", 0, options.c_str()) == 0) {
      mounted_ = true;
    } else {
      error_ = std::strerror(errno);
    }
  }
  ~SmallTmpfs() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
    if (!dir_.empty()) ::rmdir(dir_.c_str());
  }
  bool mounted() const { return mounted_; }
  const std::string& error() const { return error_; }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
  std::string error_ = "mkdtemp failed";
  bool mounted_ = false;
};

// F3: a ring larger than the room where it lives is refused at creation, naming the bytes
// needed and free, and leaves nothing behind (no SIGBUS at the first write of a missing page).
TEST(RingNamespace, RingLargerThanTheFreeSpaceIsRefusedNamingBothSizes) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a small tmpfs for the ring";
  const SmallTmpfs tmpfs(1 << 20);
  if (!tmpfs.mounted()) GTEST_SKIP() << "cannot mount a tmpfs here: " << tmpfs.error();
  shm::RingConfig config = small_test_config(tmpfs.dir() + "/ring");
  config.slot_count = 512;  // far more than 1 MiB
  const std::uint64_t needed =
      shm::RingLayout::compute(config.geometry, config.slot_count, config.slot_payload_capacity)
          .total_bytes;
  ASSERT_GT(needed, 1u << 20);
  const std::string message =
      expect_ring_error([&] { (void)shm::RingWriter::create(config); }, shm::RingErrc::no_space);
  EXPECT_NE(message.find("needs " + std::to_string(needed) + " bytes"), std::string::npos)
      << message;
  EXPECT_NE(message.find("bytes free"), std::string::npos) << message;
  EXPECT_FALSE(std::filesystem::exists(config.name)) << "nothing half-made is left";
}

}  // namespace
}  // namespace ioct::ring_test
