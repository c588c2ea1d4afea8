// The one rule every command ends by: an error's category decides its words and its exit status,
// whatever type carries it.
#include "ioct/common/command_main.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/common/error.hpp"
#include "ioct/common/input_file.hpp"
#include "ioct/config/config_file_error.hpp"
#include "ioct/shm/ring_error.hpp"

namespace ioct {
namespace {

template <typename Thrown>
std::pair<int, std::string> ending_of(const Thrown& error, const FlagForKey& flag_for = {}) {
  testing::internal::CaptureStderr();
  const int status = run_command(
      "ioct-x", [&]() -> int { throw error; }, flag_for);
  return {status, testing::internal::GetCapturedStderr()};
}

TEST(CommandMain, EachCategoryHasItsWordsAndItsExitStatus) {
  const auto flags = [](const std::string& key) {
    return key == "ring.slots" ? std::string("--slots") : std::string();
  };
  EXPECT_EQ(
      ending_of(ConfigError("ring.slots", "1", "must be in [2, 4096]"), flags),
      std::make_pair(kExitRefused, std::string("ioct-x: invalid configuration: ring.slots = "
                                               "1: must be in [2, 4096] (option --slots)\n")));
  EXPECT_EQ(ending_of(ConfigError("galvo.max_velocity", "0", "must be positive"), flags).second,
            "ioct-x: invalid configuration: galvo.max_velocity = 0: must be positive\n")
      << "no flag sets it: none named";
  EXPECT_EQ(ending_of(config::ConfigFileError("rt.toml", {3, 1}, "x: unknown key")),
            std::make_pair(kExitRefused,
                           std::string("ioct-x: invalid configuration: rt.toml:3:1: x: unknown "
                                       "key\n")));
  EXPECT_EQ(ending_of(InputFileError("input file", "v.nrrd", "it is a FIFO")),
            std::make_pair(kExitFailed, std::string("ioct-x: bad input: cannot read input file "
                                                    "'v.nrrd': it is a FIFO\n")));
  EXPECT_EQ(ending_of(shm::RingError(shm::RingErrc::not_found, "no ring 'r'")),
            std::make_pair(kExitFailed, std::string("ioct-x: error: no ring 'r'\n")));
  EXPECT_EQ(ending_of(shm::RingError(shm::RingErrc::bad_config, "ring: name = 'a/b' ...")).first,
            kExitRefused);
  EXPECT_EQ(ending_of(shm::RingError(shm::RingErrc::corrupt, "slot 3 torn")).second,
            "ioct-x: bad input: slot 3 torn\n");
  EXPECT_EQ(ending_of(std::logic_error("a bug")),
            std::make_pair(kExitFailed, std::string("ioct-x: error: a bug\n")));
  EXPECT_EQ(run_command("ioct-x", [] { return 7; }), 7) << "the body's own status";
}

TEST(CommandMain, ACategoryIsFoundWhateverTheStandardBaseOfTheError) {
  EXPECT_EQ(category_of(ConfigError("k", "v", "a")), ErrorCategory::config);
  EXPECT_EQ(category_of(shm::RingError(shm::RingErrc::permission, "p")),
            ErrorCategory::environment);
  EXPECT_EQ(category_of(std::runtime_error("r")), ErrorCategory::internal);
  const ConfigError keyed("ring.slots", "1", "x");
  EXPECT_EQ(keyed.key(), "ring.slots");
  EXPECT_EQ(exit_status(ErrorCategory::device), kExitFailed);
  EXPECT_EQ(exit_status(ErrorCategory::config), kExitRefused);
}

}  // namespace
}  // namespace ioct
