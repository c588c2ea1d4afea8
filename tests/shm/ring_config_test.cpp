// Bad geometry and config are refused with RingError(bad_config) and a message naming the
// value, before any object is made.
#include <gtest/gtest.h>

#include <cctype>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/shm/shm_object.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

using test_support::ScopedShmName;

struct BadConfig {
  std::string what;
  std::function<void(shm::RingConfig&)> change;
  std::vector<std::string> message_has;
};

void PrintTo(const BadConfig& c, std::ostream* os) {
  *os << c.what;
}

// The full-size geometry of the design brief: 1376 x 512 x 16 x 2 bytes, 22.5 MB per group.
void full_size_geometry(shm::RingConfig& c) {
  c.geometry.samples_per_ascan = 1376;
  c.geometry.ascans_per_bscan = 512;
  c.geometry.bscans_per_group = 16;
}

std::vector<BadConfig> bad_configs() {
  return {
      {"payload larger than the slot",
       [](shm::RingConfig& c) {
         full_size_geometry(c);
         c.slot_payload_capacity = 4096;
       },
       {"22544384 bytes", "slot_payload_capacity = 4096"}},
      {"zero slots", [](shm::RingConfig& c) { c.slot_count = 0; }, {"slot_count = 0"}},
      {"one slot", [](shm::RingConfig& c) { c.slot_count = 1; }, {"slot_count = 1"}},
      {"too many slots",
       [](shm::RingConfig& c) { c.slot_count = (1u << 20) + 1; },
       {"slot_count = 1048577"}},
      {"slot capacity overflows when page-aligned",
       [](shm::RingConfig& c) { c.slot_payload_capacity = UINT64_MAX; },
       {"slot_payload_capacity = 18446744073709551615", "overflows"}},
      {"ring size overflows 64 bits",
       [](shm::RingConfig& c) {
         c.slot_count = 1u << 20;
         c.slot_payload_capacity = std::uint64_t{1} << 50;
       },
       {"slot_count = 1048576", "1125899906842624 bytes", "overflow"}},
      {"ring size above the limit",
       [](shm::RingConfig& c) {
         c.slot_count = 1024;
         c.slot_payload_capacity = std::uint64_t{1} << 31;
       },
       {"slot_count = 1024", "above the limit"}},
      {"bytes_per_sample 3",
       [](shm::RingConfig& c) { c.geometry.bytes_per_sample = 3; },
       {"bytes_per_sample = 3"}},
      {"bytes_per_sample 0",
       [](shm::RingConfig& c) { c.geometry.bytes_per_sample = 0; },
       {"bytes_per_sample = 0"}},
      {"zero samples per A-scan",
       [](shm::RingConfig& c) { c.geometry.samples_per_ascan = 0; },
       {"samples_per_ascan = 0"}},
      {"too many A-scans per B-scan",
       [](shm::RingConfig& c) { c.geometry.ascans_per_bscan = 70000; },
       {"ascans_per_bscan = 70000"}},
      {"more B-scans per group than markers",
       [](shm::RingConfig& c) { c.geometry.bscans_per_group = shm::kMaxBscansPerGroup + 1; },
       {"bscans_per_group = " + std::to_string(shm::kMaxBscansPerGroup + 1)}},
      {"zero B-scans per volume",
       [](shm::RingConfig& c) { c.geometry.bscans_per_volume = 0; },
       {"bscans_per_volume = 0"}},
      {"empty name", [](shm::RingConfig& c) { c.name = ""; }, {"name = ''"}},
      {"name with a slash",
       [](shm::RingConfig& c) { c.name = "/ioct-ring"; },
       {"name = '/ioct-ring'"}},
      {"name with a slash inside",
       [](shm::RingConfig& c) { c.name = "ioct/ring"; },
       {"name = 'ioct/ring'"}},
      {"name too long",
       [](shm::RingConfig& c) { c.name = std::string(201, 'r'); },
       {"name = 'rrrr", "200 characters"}},
      {"mode the owner cannot write", [](shm::RingConfig& c) { c.mode = 0440; }, {"mode = "}},
      {"mode with set-id bits", [](shm::RingConfig& c) { c.mode = 04640; }, {"mode = "}},
      // Issue F2: whoever may write the ring may truncate it under the producer (SIGBUS).
      {"mode the group may write", [](shm::RingConfig& c) { c.mode = 0660; }, {"mode = 0660"}},
      {"mode anyone may write", [](shm::RingConfig& c) { c.mode = 0642; }, {"mode = 0642"}},
      {"mode zero", [](shm::RingConfig& c) { c.mode = 0; }, {"mode = "}},
  };
}

class RingBadConfig : public ::testing::TestWithParam<BadConfig> {};

void expect_bad_config(const std::function<void()>& attempt,
                       const std::vector<std::string>& message_has) {
  try {
    attempt();
    ADD_FAILURE() << "accepted";
  } catch (const shm::RingError& e) {
    EXPECT_EQ(e.code(), shm::RingErrc::bad_config) << shm::to_string(e.code()) << ": " << e.what();
    for (const std::string& word : message_has) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos)
          << "'" << word << "' missing from: " << e.what();
    }
  }
}

TEST_P(RingBadConfig, IsRefusedNamingTheValueAndMakesNoObject) {
  const ScopedShmName name("config");
  shm::RingConfig config = small_test_config(name.str());
  GetParam().change(config);
  expect_bad_config([&] { config.validate(); }, GetParam().message_has);
  expect_bad_config([&] { shm::RingWriter::create(config); }, GetParam().message_has);
  EXPECT_FALSE(shm::ShmObject::exists(name.str()));
  if (!config.name.empty() && config.name.find('/') == std::string::npos) {
    EXPECT_FALSE(shm::ShmObject::exists(config.name));
  }
}

INSTANTIATE_TEST_SUITE_P(Cases, RingBadConfig, ::testing::ValuesIn(bad_configs()),
                         [](const ::testing::TestParamInfo<BadConfig>& param_info) {
                           std::string id;
                           for (const char ch : param_info.param.what) {
                             if (std::isalnum(static_cast<unsigned char>(ch))) id += ch;
                           }
                           return id;
                         });

TEST(RingConfig, GoodConfigsAreAccepted) {
  const ScopedShmName name("config-good");
  EXPECT_NO_THROW(small_test_config(name.str()).validate());
  shm::RingConfig full;
  full.name = name.str();
  EXPECT_NO_THROW(full.validate()) << "the default geometry of the design brief";
  shm::RingConfig exactly_full = small_test_config(name.str());
  exactly_full.slot_payload_capacity = exactly_full.geometry.group_payload_bytes();
  EXPECT_NO_THROW(exactly_full.validate()) << "a payload that fills the slot exactly";
}

TEST(RingConfig, GeometryProductThatOverflowsIsRefused) {
  shm::RingGeometry g;
  g.samples_per_ascan = UINT32_MAX;
  g.ascans_per_bscan = UINT32_MAX;
  g.bscans_per_group = UINT32_MAX;
  g.bytes_per_sample = 4;
  expect_bad_config([&] { (void)g.group_payload_bytes(); }, {"overflows 64 bits"});
  expect_bad_config([&] { g.validate(); }, {"samples_per_ascan = 4294967295"});
}

// The mode is an octal permission and reads as one.
TEST(RingConfig, BadModeIsNamedInOctal) {
  shm::RingConfig config = small_test_config("ioct-test-mode");
  config.mode = 0440;
  expect_bad_config([&] { config.validate(); }, {"mode = 0440"});
}

}  // namespace
}  // namespace ioct::ring_test
