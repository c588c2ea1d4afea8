#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "ioct/common/config_error.hpp"
#include "operator_token.hpp"

namespace ioct::view {
namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("ioct-token-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

std::string refusal(const fs::path& file) {
  try {
    (void)OperatorToken::read(file);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(OperatorToken, AMadeTokenIsPrivateStableAndMatches) {
  const fs::path file = scratch("made");
  fs::remove(file);
  const OperatorToken made = OperatorToken::read_or_make(file);
  EXPECT_EQ(made.value().size(), 32u);
  struct stat st {};
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(OperatorToken::read_or_make(file).value(), made.value()) << "kept across restarts";
  EXPECT_TRUE(made.matches(made.value()));
  EXPECT_FALSE(made.matches(made.value().substr(1)));
  EXPECT_FALSE(made.matches(""));
  std::string wrong = made.value();
  wrong.back() = wrong.back() == 'a' ? 'b' : 'a';
  EXPECT_FALSE(made.matches(wrong));
  fs::remove_all(file.parent_path());
}

TEST(OperatorToken, BadFilesAreRefusedNamingTheKey) {
  const fs::path open = scratch("open");
  std::ofstream(open) << "0123456789abcdef0123\n";
  fs::permissions(open, fs::perms::owner_read | fs::perms::others_read);
  EXPECT_NE(refusal(open).find("view.token_file"), std::string::npos);
  EXPECT_NE(refusal(open).find("owner only"), std::string::npos);

  const fs::path short_token = scratch("short");
  std::ofstream(short_token) << "abc\n";
  fs::permissions(short_token, fs::perms::owner_read);
  EXPECT_NE(refusal(short_token).find("16 to 256"), std::string::npos);

  const fs::path fifo = scratch("fifo");
  ::mkfifo(fifo.c_str(), 0600);
  EXPECT_NE(refusal(fifo).find("regular file"), std::string::npos) << "a FIFO must not hang us";

  EXPECT_NE(refusal(scratch("missing")).find("cannot be opened"), std::string::npos);
  fs::remove_all(open.parent_path());
}

}  // namespace
}  // namespace ioct::view
