// ioct-record's control language in-process: recording names (no path, no control bytes,
// bounded, ".h5" added), and the refusals of malformed or unknown commands, each naming the
// command and the value.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/ringrec/recorder_control.hpp"
#include "ioct/ringrec/ring_recorder.hpp"

namespace ioct::ringrec {
namespace {

namespace fs = std::filesystem;

std::string refusal_of_name(const std::string& name) {
  try {
    recording_file("/data", name);
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "name");
    return e.what();
  }
  return "";
}

TEST(RecordingName, APlainNameIsAFileInTheDirectoryWithH5Added) {
  EXPECT_EQ(recording_file("/data", "run-7"), fs::path("/data/run-7.h5"));
  EXPECT_EQ(recording_file("/data", "run-7.h5"), fs::path("/data/run-7.h5"));
  EXPECT_EQ(recording_file("/data", "patient 12 OD"), fs::path("/data/patient 12 OD.h5"));
}

TEST(RecordingName, PathsControlBytesDotsAndLongNamesAreRefused) {
  EXPECT_NE(refusal_of_name("../etc/x").find("path separator"), std::string::npos);
  EXPECT_NE(refusal_of_name("a/b").find("path separator"), std::string::npos);
  EXPECT_NE(refusal_of_name("a\\b").find("path separator"), std::string::npos);
  EXPECT_NE(refusal_of_name(std::string("a\nb")).find("control bytes"), std::string::npos);
  EXPECT_NE(refusal_of_name(std::string("a\x7f")).find("control bytes"), std::string::npos);
  EXPECT_NE(refusal_of_name(std::string("a\0b", 3)).find("control bytes"), std::string::npos);
  EXPECT_NE(refusal_of_name("").find("empty"), std::string::npos);
  EXPECT_NE(refusal_of_name("..").find("dots"), std::string::npos);
  EXPECT_NE(refusal_of_name(std::string(kMaxRecordingNameBytes + 1, 'x')).find("at most"),
            std::string::npos);
  EXPECT_NE(refusal_of_name(std::string(kMaxRecordingNameBytes, 'x')).find(".h5"),
            std::string::npos);
  EXPECT_EQ(refusal_of_name(std::string(kMaxRecordingNameBytes - 3, 'x')), "");
}

class RecorderControlTest : public ::testing::Test {
 protected:
  RecorderControlTest() : recorder_(config()) {}
  static RecorderConfig config() {
    RecorderConfig c;
    c.standby = true;
    c.out = fs::temp_directory_path();
    return c;
  }
  nlohmann::json reply(const std::string& line) {
    const nlohmann::json parsed = nlohmann::json::parse(recorder_control_reply(recorder_, line));
    EXPECT_TRUE(parsed.contains("ok")) << parsed.dump();
    return parsed;
  }
  std::string error(const std::string& line) {
    const nlohmann::json r = reply(line);
    EXPECT_FALSE(r.value("ok", true)) << line << " -> " << r.dump();
    return r.value("error", "");
  }
  RingRecorder recorder_;
};

TEST_F(RecorderControlTest, MalformedAndUnknownCommandsAreRefusedNamingWhat) {
  EXPECT_NE(error("not json").find("one JSON object per line"), std::string::npos);
  EXPECT_NE(error("[1]").find("one JSON object per line"), std::string::npos);
  EXPECT_NE(error(R"({"cmd": "record-stop", "cmd": "record-start"})").find("given twice"),
            std::string::npos);
  EXPECT_NE(error(R"({"cmd": "start"})").find("unknown verb \"start\""), std::string::npos);
  EXPECT_NE(error(R"({"name": "x"})").find("\"cmd\""), std::string::npos);
  EXPECT_NE(error(R"({"cmd": "record-start"})").find("needs \"name\""), std::string::npos);
  EXPECT_NE(error(R"({"cmd": "record-start", "name": 7})").find("needs \"name\""),
            std::string::npos);
  EXPECT_NE(error(R"({"cmd": "record-start", "name": "x", "seconds": "10"})")
                .find("seconds = \"10\": must be a number"),
            std::string::npos);
  EXPECT_NE(error(R"({"cmd": "record-start", "name": "x", "seconds": -1})").find("seconds = -1"),
            std::string::npos);
  EXPECT_NE(error(R"({"cmd": "record-start", "name": "x", "path": "/"})")
                .find("unexpected member \"path\""),
            std::string::npos);
  EXPECT_NE(error(R"({"cmd": "record-stop", "name": "x"})").find("unexpected member"),
            std::string::npos);
  EXPECT_NE(error(R"({"cmd": "record-start", "name": "../x"})").find("record-start: name = '../x'"),
            std::string::npos);
  const nlohmann::json r = reply(R"({"cmd": "record-stop", "id": 42})");
  EXPECT_EQ(r.value("id", 0), 42);
  EXPECT_EQ(r.value("cmd", ""), "record-stop");
}

TEST_F(RecorderControlTest, StatusOfARecorderNotRecording) {
  const nlohmann::json r = reply(R"({"cmd": "record-status", "id": "a"})");
  ASSERT_TRUE(r.value("ok", false)) << r.dump();
  EXPECT_EQ(r["id"], "a");
  const nlohmann::json& s = r["status"];
  EXPECT_FALSE(s["recording"].get<bool>());
  EXPECT_TRUE(s["standby"].get<bool>());
  EXPECT_TRUE(s["file"].is_null());
  EXPECT_EQ(s["groups_written"], 0);
  EXPECT_EQ(s["dropped"]["queue_full"], 0);
  EXPECT_TRUE(s["last"].is_null());
}

}  // namespace
}  // namespace ioct::ringrec
