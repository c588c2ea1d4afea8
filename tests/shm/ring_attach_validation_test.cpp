// A reader attaching to something that is not a healthy ring -- empty, truncated, foreign, of
// another layout version, not yet initialised, self-contradicting, closed -- gets a RingError
// with the right code and a message naming the problem. Never a crash, and nothing left behind.
//
// The objects are made here with shm_open + ftruncate + mmap: a copy of a real ring's bytes,
// then one field tampered with.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

using test_support::ScopedShmName;

// A shared-memory object of `bytes` bytes filled by `fill`, made without the ring library.
void make_object(const std::string& name, std::size_t bytes,
                 const std::function<void(std::byte*)>& fill = {}) {
  const int fd = ::shm_open(name.c_str(), O_CREAT | O_EXCL | O_RDWR, 0600);
  if (fd < 0) throw std::runtime_error("shm_open " + name + ": " + std::strerror(errno));
  if (::ftruncate(fd, static_cast<off_t>(bytes)) != 0) {
    ::close(fd);
    throw std::runtime_error("ftruncate " + name);
  }
  if (bytes > 0 && fill) {
    void* p = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (p == MAP_FAILED) {
      ::close(fd);
      throw std::runtime_error("mmap " + name);
    }
    fill(static_cast<std::byte*>(p));
    ::munmap(p, bytes);
  }
  ::close(fd);
}

// The bytes of a live ring with a few groups published, and its layout.
struct RingImage {
  std::vector<std::byte> bytes;
  shm::RingLayout layout;
};

RingImage live_ring_image() {
  const ScopedShmName name("image");
  shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str(), 4));
  for (int i = 0; i < 6; ++i) publish_test_group(writer);
  shm::ReaderOptions options;
  options.publish_status = false;
  const shm::RingReader reader = shm::RingReader::attach(name.str(), options);
  RingImage image;
  image.bytes.assign(reader.mapping(), reader.mapping() + reader.mapping_bytes());
  image.layout = reader.layout();
  return image;
}

class RingAttachValidation : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { image_ = new RingImage(live_ring_image()); }
  static void TearDownTestSuite() {
    delete image_;
    image_ = nullptr;
  }

  // An object holding the first `bytes` bytes of the live ring's image with its header changed
  // by `tamper`.
  void make_tampered(std::size_t bytes, const std::function<void(shm::RingHeader&)>& tamper) {
    make_object(name_.str(), bytes, [&](std::byte* p) {
      std::memcpy(p, image_->bytes.data(), std::min(bytes, image_->bytes.size()));
      if (bytes >= sizeof(shm::RingHeader)) tamper(*reinterpret_cast<shm::RingHeader*>(p));
    });
  }
  void make_tampered(const std::function<void(shm::RingHeader&)>& tamper) {
    make_tampered(image_->bytes.size(), tamper);
  }

  // Attaching fails with `code` and a message holding every one of `words`.
  void expect_attach_fails(shm::RingErrc code, const std::vector<std::string>& words) {
    try {
      shm::RingReader::attach(name_.str());
      ADD_FAILURE() << "attached to a bad object";
    } catch (const shm::RingError& e) {
      EXPECT_EQ(e.code(), code) << "got " << shm::to_string(e.code()) << ": " << e.what();
      for (const std::string& word : words) {
        EXPECT_NE(std::string(e.what()).find(word), std::string::npos)
            << "'" << word << "' missing from: " << e.what();
      }
      EXPECT_NE(std::string(e.what()).find(name_.str()), std::string::npos)
          << "the message names the object: " << e.what();
    }
    EXPECT_TRUE(test_support::shm_objects_with_prefix(name_.str() + ".").empty())
        << "a failed attach left a reader status object behind";
  }

  static RingImage* image_;
  ScopedShmName name_{"attach"};
};

RingImage* RingAttachValidation::image_ = nullptr;

TEST_F(RingAttachValidation, AnUntamperedCopyAttaches) {
  // The baseline: the copying itself yields a valid ring, so each failure below is the tamper's.
  make_tampered([](shm::RingHeader&) {});
  const shm::RingReader reader = shm::RingReader::attach(name_.str());
  EXPECT_EQ(reader.layout().total_bytes, image_->layout.total_bytes);
}

TEST_F(RingAttachValidation, MissingObject) {
  expect_attach_fails(shm::RingErrc::not_found, {"does not exist"});
}

// What a reader sees between the producer's create and its sizing: transient, so waiting
// readers retry it.
TEST_F(RingAttachValidation, EmptyObject) {
  make_object(name_.str(), 0);
  expect_attach_fails(shm::RingErrc::not_ready, {"0 bytes", "not sized it yet"});
}

TEST_F(RingAttachValidation, ObjectOf100Bytes) {
  make_tampered(100, [](shm::RingHeader&) {});
  expect_attach_fails(shm::RingErrc::too_small, {"100 bytes"});
}

TEST_F(RingAttachValidation, HeaderDescribesMoreThanTheObjectHolds) {
  const std::size_t short_by_one_slot = image_->bytes.size() - image_->layout.slot_stride;
  make_tampered(short_by_one_slot, [](shm::RingHeader&) {});
  expect_attach_fails(shm::RingErrc::too_small, {std::to_string(image_->layout.total_bytes),
                                                 std::to_string(short_by_one_slot), "truncated"});
}

TEST_F(RingAttachValidation, NotYetInitialised) {
  make_object(name_.str(), image_->bytes.size(), [](std::byte*) {});  // all zero
  expect_attach_fails(shm::RingErrc::not_ready, {"initialising"});
}

TEST_F(RingAttachValidation, MagicNotYetPublished) {
  make_tampered([](shm::RingHeader& h) { h.magic = 0; });
  expect_attach_fails(shm::RingErrc::not_ready, {"initialising"});
}

TEST_F(RingAttachValidation, BeingReinitialised) {
  make_tampered([](shm::RingHeader& h) {
    h.state = static_cast<std::uint64_t>(shm::RingState::initializing);
  });
  expect_attach_fails(shm::RingErrc::not_ready, {"initialising"});
}

TEST_F(RingAttachValidation, ForeignMagic) {
  make_tampered([](shm::RingHeader& h) { h.magic = 0x0123456789ABCDEFu; });
  expect_attach_fails(shm::RingErrc::foreign, {"0x0123456789abcdef", "not an ioct ring"});
}

TEST_F(RingAttachValidation, ForeignBytes) {
  make_object(name_.str(), 3 * 4096, [](std::byte* p) { std::memset(p, 0xA5, 3 * 4096); });
  expect_attach_fails(shm::RingErrc::foreign, {"0xa5a5a5a5a5a5a5a5"});
}

TEST_F(RingAttachValidation, WrongLayoutVersion) {
  make_tampered([](shm::RingHeader& h) { h.layout_version = shm::kRingLayoutVersion + 1; });
  expect_attach_fails(shm::RingErrc::wrong_version,
                      {"layout version " + std::to_string(shm::kRingLayoutVersion + 1)});
}

TEST_F(RingAttachValidation, ClosedRing) {
  make_tampered(
      [](shm::RingHeader& h) { h.state = static_cast<std::uint64_t>(shm::RingState::closed); });
  expect_attach_fails(shm::RingErrc::producer_gone, {"closed"});
}

TEST_F(RingAttachValidation, RetiredRing) {
  make_tampered(
      [](shm::RingHeader& h) { h.state = static_cast<std::uint64_t>(shm::RingState::retired); });
  expect_attach_fails(shm::RingErrc::producer_gone, {"retired"});
}

TEST_F(RingAttachValidation, HeaderOfAnotherSize) {
  make_tampered([](shm::RingHeader& h) { h.header_bytes = 17; });
  expect_attach_fails(shm::RingErrc::corrupt, {"header_bytes = 17"});
}

TEST_F(RingAttachValidation, SlotHeaderOfAnotherSize) {
  make_tampered([](shm::RingHeader& h) { h.slot_header_bytes += 8; });
  expect_attach_fails(shm::RingErrc::corrupt, {"slot_header_bytes"});
}

TEST_F(RingAttachValidation, InvalidGeometry) {
  make_tampered([](shm::RingHeader& h) { h.geometry.bytes_per_sample = 3; });
  expect_attach_fails(shm::RingErrc::corrupt, {"bytes_per_sample = 3"});
}

TEST_F(RingAttachValidation, ZeroSlots) {
  make_tampered([](shm::RingHeader& h) { h.slot_count = 0; });
  expect_attach_fails(shm::RingErrc::corrupt, {"slot_count = 0"});
}

TEST_F(RingAttachValidation, SlotCountBeyondAnyRing) {
  make_tampered([](shm::RingHeader& h) { h.slot_count = std::uint64_t{1} << 40; });
  expect_attach_fails(shm::RingErrc::corrupt, {"slot_count = " + std::to_string(1ull << 40)});
}

TEST_F(RingAttachValidation, SlotCapacityThatOverflows) {
  make_tampered([](shm::RingHeader& h) { h.slot_payload_capacity = UINT64_MAX; });
  expect_attach_fails(shm::RingErrc::corrupt, {"slot_payload_capacity", "overflows"});
}

TEST_F(RingAttachValidation, SlotStrideContradictsGeometry) {
  make_tampered([](shm::RingHeader& h) { h.slot_stride += shm::kPageBytes; });
  expect_attach_fails(shm::RingErrc::corrupt, {"slot_stride"});
}

TEST_F(RingAttachValidation, GroupSizeContradictsGeometry) {
  make_tampered([](shm::RingHeader& h) { h.group_payload_bytes += 8; });
  expect_attach_fails(shm::RingErrc::corrupt, {"group_payload_bytes"});
}

TEST_F(RingAttachValidation, FirstSlotOffsetContradictsGeometry) {
  make_tampered([](shm::RingHeader& h) { h.first_slot_offset = 0; });
  expect_attach_fails(shm::RingErrc::corrupt, {"first_slot_offset"});
}

TEST_F(RingAttachValidation, TotalSizeContradictsGeometry) {
  make_tampered([](shm::RingHeader& h) { h.total_bytes -= shm::kPageBytes; });
  expect_attach_fails(shm::RingErrc::corrupt, {"total_bytes"});
}

TEST_F(RingAttachValidation, UnknownStateIsRefused) {
  make_tampered([](shm::RingHeader& h) { h.state = 99; });
  expect_attach_fails(shm::RingErrc::corrupt, {"state = 99"});
}

TEST_F(RingAttachValidation, ProducerRefusesToTakeOverAForeignObject) {
  make_object(name_.str(), 3 * 4096, [](std::byte* p) { std::memset(p, 0xA5, 3 * 4096); });
  try {
    shm::RingWriter::create(small_test_config(name_.str()));
    ADD_FAILURE() << "a producer took over a foreign object";
  } catch (const shm::RingError& e) {
    EXPECT_EQ(e.code(), shm::RingErrc::foreign) << e.what();
    EXPECT_NE(std::string(e.what()).find("not an ioct ring"), std::string::npos) << e.what();
  }
  // Untouched: still the foreign bytes.
  expect_attach_fails(shm::RingErrc::foreign, {"0xa5a5a5a5a5a5a5a5"});
}

}  // namespace
}  // namespace ioct::ring_test
