// The ring object gets the configured mode (0640 by default: the owner writes, the group reads)
// whatever the process umask, and
// the configured group; an unknown group is refused and leaves no object behind.
#include <fcntl.h>
#include <grp.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>

#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/shm/shm_object.hpp"
#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "peer_line.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

using namespace std::chrono_literals;
using test_support::ScopedShmName;

class UmaskGuard {
 public:
  explicit UmaskGuard(mode_t mask) : previous_(::umask(mask)) {}
  ~UmaskGuard() { ::umask(previous_); }

 private:
  mode_t previous_;
};

struct stat stat_of(const std::string& shm_name) {
  const std::string path = "/dev/shm/" + shm_name;
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw std::runtime_error("open " + path);
  struct stat st {};
  const int rc = ::fstat(fd, &st);
  ::close(fd);
  if (rc != 0) throw std::runtime_error("fstat " + path);
  return st;
}

mode_t permissions_of(const std::string& shm_name) {
  return stat_of(shm_name).st_mode & 07777;
}

TEST(RingPermissions, RingGetsMode0640WhateverTheUmask) {
  for (const mode_t mask : {mode_t{0077}, mode_t{0027}, mode_t{0}, mode_t{0777}}) {
    SCOPED_TRACE("umask 0" + std::to_string(mask));
    const ScopedShmName name("mode");
    const UmaskGuard umask(mask);
    const shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str()));
    EXPECT_EQ(permissions_of(name.str()), 0640u);
  }
}

TEST(RingPermissions, RingGetsTheConfiguredMode) {
  const ScopedShmName name("mode-0600");
  const UmaskGuard umask(0077);
  shm::RingConfig config = small_test_config(name.str());
  config.mode = 0600;
  const shm::RingWriter writer = shm::RingWriter::create(config);
  EXPECT_EQ(permissions_of(name.str()), 0600u);
}

TEST(RingPermissions, ReaderStatusObjectGetsItsModeWhateverTheUmask) {
  const ScopedShmName name("status-mode");
  const shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str()));
  const UmaskGuard umask(0077);
  const shm::RingReader reader = shm::RingReader::attach(name.str());
  EXPECT_EQ(permissions_of(*reader.status_object_name()), 0640u);
}

TEST(RingPermissions, ModeIsRestoredWhenADeadProducersRingIsReused) {
  const ScopedShmName name("mode-reuse");
  {
    // A producer that dies leaves its ring behind; someone narrowed its mode meanwhile.
    test_support::ChildProcess dead = test_support::ChildProcess::spawn(
        test_support::sibling_executable("ring_stress_peer"), {"writer", "--ring", name.str()});
    const auto line = dead.read_line(30s);
    ASSERT_TRUE(line && parse_peer_line(*line)->kind == "ready");
    dead.kill_and_wait();
  }
  ASSERT_EQ(::chmod(("/dev/shm/" + name.str()).c_str(), 0600), 0);
  const UmaskGuard umask(0077);
  const shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str()));
  EXPECT_EQ(writer.startup_action(), shm::StartupAction::reused_stale);
  EXPECT_EQ(permissions_of(name.str()), 0640u);
}

TEST(RingPermissions, RingIsGivenToTheConfiguredGroup) {
  const ScopedShmName name("group");
  const group* own = ::getgrgid(::getegid());
  ASSERT_NE(own, nullptr) << "this process's group has no name";
  shm::RingConfig config = small_test_config(name.str());
  config.group = own->gr_name;
  const shm::RingWriter writer = shm::RingWriter::create(config);
  EXPECT_EQ(stat_of(name.str()).st_gid, ::getegid());
  EXPECT_EQ(permissions_of(name.str()), 0640u);
}

TEST(RingPermissions, UnknownGroupIsRefusedAndLeavesNoObject) {
  const ScopedShmName name("no-group");
  shm::RingConfig config = small_test_config(name.str());
  config.group = "ioct-no-such-group-" + std::to_string(::getpid());
  ASSERT_EQ(::getgrnam(config.group.c_str()), nullptr);
  try {
    shm::RingWriter::create(config);
    ADD_FAILURE() << "a ring was made for an unknown group";
  } catch (const shm::RingError& e) {
    EXPECT_EQ(e.code(), shm::RingErrc::bad_config) << e.what();
    EXPECT_NE(std::string(e.what()).find("group '" + config.group + "' does not exist"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(shm::ShmObject::exists(name.str()));
  EXPECT_TRUE(test_support::shm_objects_with_prefix(name.str()).empty());
}

}  // namespace
}  // namespace ioct::ring_test
