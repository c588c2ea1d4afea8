// ViewRequests: each request of the view socket's table on a ViewControl that records what it was
// asked, and every kind of bad line refused with a reply naming the key, changing nothing.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/live_stages/view_requests.hpp"
#include "ioct/gpu/render/render_params_json.hpp"
#include "recording_control.hpp"

namespace ioct::gpu::live {
namespace {

using nlohmann::json;

class ViewRequestsTest : public ::testing::Test {
 protected:
  void TearDown() override { std::filesystem::remove_all(root_); }
  json ask(const std::string& line, std::uint64_t client = 1) {
    return requests_.handle(line, client);
  }
  void expect_refused(const std::string& line, const std::string& key) {
    const std::uint64_t generation = control_.generation;
    const json reply = ask(line);
    EXPECT_EQ(reply.value("ok", true), false) << line << " -> " << reply.dump();
    EXPECT_EQ(reply.value("key", ""), key) << line << " -> " << reply.dump();
    EXPECT_FALSE(reply.value("error", "").empty());
    EXPECT_EQ(control_.generation, generation) << line << " changed something";
  }

  const std::filesystem::path root_ =
      std::filesystem::temp_directory_path() /
      ("ioct-view-requests-" + std::to_string(::getpid()) + "-" +
       ::testing::UnitTest::GetInstance()->current_test_info()->name());
  const std::filesystem::path snapshots_ = root_ / "snapshots";
  RecordingControl control_;
  ViewRequests requests_{control_, snapshots_};
};

TEST_F(ViewRequestsTest, GetGivesTheParametersAndTheirGeneration) {
  const json reply = ask(R"({"cmd":"get"})");
  EXPECT_EQ(reply.at("ok"), true);
  EXPECT_EQ(reply.at("generation"), 1);
  EXPECT_EQ(reply.at("params"), render::to_json(render::RenderConfig{}));
}

TEST_F(ViewRequestsTest, InstrumentsGivesTheControlsFindingsAndTakesNoFields) {
  // RecordingControl keeps ViewControl's default: the detection does not run.
  EXPECT_EQ(ask(R"({"cmd":"instruments"})"),
            json({{"ok", true}, {"instruments", {{"enabled", false}}}}));
  expect_refused(R"({"cmd":"instruments","view":1})", "view");
}

TEST_F(ViewRequestsTest, SetChangesTheParameters) {
  const json reply =
      ask(R"({"cmd":"set","changes":{"enhanced":{"threshold":0.5},"mode":"basic"}})");
  EXPECT_EQ(reply, json({{"ok", true}, {"generation", 2}}));
  EXPECT_DOUBLE_EQ(control_.config.enhanced.threshold, 0.5);
  EXPECT_EQ(control_.config.mode, render::RenderMode::basic);
}

TEST_F(ViewRequestsTest, ARangeErrorNamesTheKeyAndChangesNothing) {
  const json reply = ask(R"({"cmd":"set","changes":{"enhanced":{"kg1":-1}}})");
  EXPECT_EQ(reply.at("ok"), false);
  EXPECT_EQ(reply.at("key"), "render.enhanced.kg1");
  EXPECT_NE(reply.at("error").get<std::string>().find("render.enhanced.kg1 = -1"),
            std::string::npos)
      << reply;
  EXPECT_EQ(control_.generation, 1u);
  expect_refused(R"({"cmd":"set","changes":{"enhanced":{"kg1":"big"}}})", "render.enhanced.kg1");
  expect_refused(R"({"cmd":"set","changes":{"lighting":1}})", "render.lighting");
}

TEST_F(ViewRequestsTest, PrivateViewsOpenSteerAndCloseOnTheirConnection) {
  EXPECT_EQ(ask(R"({"cmd":"open_view","view":3,"changes":{"view":{"azimuth_deg":90}}})"),
            json({{"ok", true}, {"view", 3}}));
  EXPECT_TRUE(control_.open.contains(3));
  EXPECT_EQ(ask(R"({"cmd":"set","view":3,"changes":{"view":{"zoom":2}}})").at("ok"), true);
  // Only the camera of a private view, and only on the connection that opened it.
  expect_refused(R"({"cmd":"set","view":3,"changes":{"enhanced":{"kg1":2}}})", "render.enhanced");
  EXPECT_EQ(ask(R"({"cmd":"set","view":3,"changes":{}})", 2).at("key"), "view");
  EXPECT_EQ(ask(R"({"cmd":"open_view","view":3})", 2).at("key"), "view");
  EXPECT_EQ(ask(R"({"cmd":"close_view","view":3})"), json({{"ok", true}}));
  EXPECT_FALSE(control_.open.contains(3));
  expect_refused(R"({"cmd":"close_view","view":3})", "view");

  // A client that goes takes its views with it.
  ASSERT_EQ(ask(R"({"cmd":"open_view","view":4})", 5).at("ok"), true);
  requests_.client_gone(5);
  EXPECT_FALSE(control_.open.contains(4));

  // The control's refusals come back named.
  ASSERT_EQ(ask(R"({"cmd":"open_view","view":10})").at("ok"), true);
  ASSERT_EQ(ask(R"({"cmd":"open_view","view":11})").at("ok"), true);
  expect_refused(R"({"cmd":"open_view","view":12})", "view");
}

TEST_F(ViewRequestsTest, BadViewNumbersAreRefused) {
  for (const char* line :
       {R"({"cmd":"open_view"})", R"({"cmd":"open_view","view":0})",
        R"({"cmd":"open_view","view":-1})", R"({"cmd":"open_view","view":1.5})",
        R"({"cmd":"open_view","view":"1"})", R"({"cmd":"open_view","view":18446744073709551615})",
        R"({"cmd":"close_view","view":null})"}) {
    expect_refused(line, "view");
  }
}

TEST_F(ViewRequestsTest, MalformedLinesAreRefusedNamingWhatIsWrong) {
  expect_refused("{\"cmd\":\"get\"", "request");
  expect_refused("not json", "request");
  expect_refused("[1,2]", "request");
  expect_refused("\"get\"", "request");
  expect_refused(R"({"command":"get"})", "cmd");
  expect_refused(R"({"cmd":7})", "cmd");
  expect_refused(R"({"cmd":"reboot"})", "cmd");
  expect_refused(R"({"cmd":"get","extra":1})", "extra");
  expect_refused(R"({"cmd":"set"})", "changes");
  expect_refused(R"({"cmd":"set","changes":[1]})", "changes");
  expect_refused(R"({"cmd":"snapshot","name":"a","view":1})", "view");
}

TEST_F(ViewRequestsTest, DuplicateKeysAreAnErrorAtAnyDepth) {
  expect_refused(R"({"cmd":"get","cmd":"get"})", "request");
  expect_refused(R"({"cmd":"set","changes":{"enhanced":{"kg1":1,"kg1":2}}})", "request");
  const json reply =
      ask(R"({"cmd":"set","changes":{"mode":"basic"},"changes":{"mode":"enhanced"}})");
  EXPECT_NE(reply.at("error").get<std::string>().find("\"changes\""), std::string::npos) << reply;
  // The same key in two different objects is fine.
  EXPECT_EQ(
      ask(R"({"cmd":"set","changes":{"view":{"zoom":2},"enhanced":{"transfer":{"window":[0,1]}}}})")
          .at("ok"),
      true);
}

TEST_F(ViewRequestsTest, SnapshotWritesThePngAndItsParametersInTheFolder) {
  const json reply = ask(R"({"cmd":"snapshot","name":"case-7_a.b"})");
  ASSERT_EQ(reply.at("ok"), true) << reply;
  const std::filesystem::path png = reply.at("png").get<std::string>();
  const std::filesystem::path params = reply.at("json").get<std::string>();
  EXPECT_EQ(png, std::filesystem::absolute(snapshots_ / "case-7_a.b.png"));
  EXPECT_EQ(params, std::filesystem::absolute(snapshots_ / "case-7_a.b.json"));
  ASSERT_TRUE(std::filesystem::exists(png));
  std::ifstream in(params);
  const json saved = json::parse(in);
  EXPECT_EQ(saved.at("params"), render::to_json(control_.config));
  EXPECT_EQ(saved.at("group"), 42);
  // Never over an earlier one.
  expect_refused(R"({"cmd":"snapshot","name":"case-7_a.b"})", "name");
  EXPECT_EQ(control_.snapshots, 1);
  // Without a name it makes one.
  const json unnamed = ask(R"({"cmd":"snapshot"})");
  ASSERT_EQ(unnamed.at("ok"), true) << unnamed;
  EXPECT_EQ(std::filesystem::path(unnamed.at("png").get<std::string>()).parent_path(),
            std::filesystem::absolute(snapshots_));
}

TEST_F(ViewRequestsTest, SnapshotNamesCannotLeaveTheFolder) {
  for (const char* name : {"../x", "/abs", "", ".hidden", "..", "a/b", "a\\\\b", "x y",
                           "name\\u0000.png", "\\u00e9t\\u00e9"}) {
    expect_refused(std::string(R"({"cmd":"snapshot","name":")") + name + "\"}", "name");
  }
  expect_refused(R"({"cmd":"snapshot","name":7})", "name");
  expect_refused(R"({"cmd":"snapshot","name":")" + std::string(65, 'a') + "\"}", "name");
  EXPECT_EQ(control_.snapshots, 0);
  EXPECT_FALSE(std::filesystem::exists(root_ / "x.png"));
  EXPECT_FALSE(std::filesystem::exists("/abs.png"));
  EXPECT_NO_THROW(check_snapshot_name(std::string(64, 'a')));
}

TEST_F(ViewRequestsTest, ASnapshotThatCannotBeTakenIsAnErrorReply) {
  control_.snapshot_fails = true;
  const json reply = ask(R"({"cmd":"snapshot","name":"early"})");
  EXPECT_EQ(reply.at("ok"), false);
  EXPECT_EQ(reply.at("key"), "snapshot");
  EXPECT_FALSE(std::filesystem::exists(snapshots_ / "early.png"));
}

}  // namespace
}  // namespace ioct::gpu::live
