#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "static_files.hpp"

namespace ioct::view {
namespace {

namespace fs = std::filesystem;

class StaticFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("ioct-www-" + std::to_string(::getpid()));
    fs::create_directories(root_ / "js");
    std::ofstream(root_ / "index.html") << "<p>display";
    std::ofstream(root_ / "control.html") << "<p>control";
    std::ofstream(root_ / "js" / "app.js") << "export {}";
    std::ofstream(root_ / ".secret") << "no";
    std::ofstream(root_.parent_path() / ("outside-" + std::to_string(::getpid()))) << "no";
    fs::create_symlink("/etc/passwd", root_ / "link.txt");
    ::mkfifo((root_ / "fifo.html").c_str(), 0600);
  }
  void TearDown() override {
    fs::remove_all(root_);
    fs::remove(root_.parent_path() / ("outside-" + std::to_string(::getpid())));
  }
  fs::path root_;
};

TEST_F(StaticFilesTest, PagesAreFoundWithTheirType) {
  StaticFiles files(root_);
  auto index = files.find("/");
  ASSERT_TRUE(index);
  EXPECT_EQ(index->body, "<p>display");
  EXPECT_EQ(index->content_type, "text/html; charset=utf-8");
  EXPECT_EQ(files.find("/control")->body, "<p>control");
  EXPECT_EQ(files.find("/js/app.js?v=2")->content_type, "text/javascript; charset=utf-8");
}

TEST_F(StaticFilesTest, NothingOutsideTheFolderNorHiddenNorSpecial) {
  StaticFiles files(root_);
  const std::string outside = "/../outside-" + std::to_string(::getpid());
  EXPECT_FALSE(files.find(outside));
  EXPECT_FALSE(files.find("/js/../../etc/passwd"));
  EXPECT_FALSE(files.find("/.secret"));
  EXPECT_FALSE(files.find("/link.txt")) << "a symbolic link must not be followed";
  EXPECT_FALSE(files.find("/fifo.html")) << "a FIFO must be refused, not read";
  EXPECT_FALSE(files.find("/js/"));
  EXPECT_FALSE(files.find("/%2e%2e/x"));
  EXPECT_FALSE(files.find("relative"));
}

}  // namespace
}  // namespace ioct::view
