// The control channel's parser: well-formed commands, and every kind of bad line answered with a
// clear error (garbage, wrong types, unknown verbs and members, out-of-range scan values).
#include "control_protocol.hpp"

#include <gtest/gtest.h>

#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::rt {
namespace {

std::string error_of(std::string_view line) {
  const auto parsed = parse_control_line(line);
  if (const auto* e = std::get_if<ControlParseError>(&parsed)) return e->message;
  return "ok";
}

TEST(ControlProtocol, ParsesTheVerbsAndEchoesTheId) {
  const auto status = parse_control_line(R"({"cmd": "status", "id": 7})");
  ASSERT_TRUE(std::holds_alternative<ControlRequest>(status));
  EXPECT_EQ(std::get<ControlRequest>(status).verb, ControlVerb::status);
  EXPECT_EQ(std::get<ControlRequest>(status).id, 7);
  const auto scan = parse_control_line(R"({"cmd":"scan","scan":{"pattern":"radial"}})");
  ASSERT_TRUE(std::holds_alternative<ControlRequest>(scan));
  EXPECT_EQ(std::get<ControlRequest>(scan).scan_changes["pattern"], "radial");
  EXPECT_EQ(error_of(R"({"cmd":"start"})"), "ok");
  EXPECT_EQ(error_of(R"({"cmd":"stop"})"), "ok");
}

TEST(ControlProtocol, BadLinesGetClearErrors) {
  EXPECT_EQ(error_of("hello"),
            "not valid JSON: expected one object per line, like {\"cmd\": \"status\"}");
  EXPECT_EQ(error_of("\x01\xff\xfe garbage"),
            "not valid JSON: expected one object per line, like {\"cmd\": \"status\"}");
  EXPECT_EQ(error_of("[1, 2]"), "expected a JSON object, got array");
  EXPECT_EQ(error_of("{}"), "missing \"cmd\"; verbs: status, start, stop, scan");
  EXPECT_EQ(error_of(R"({"cmd": 5})"), "\"cmd\" must be a string, not number");
  EXPECT_EQ(error_of(R"({"cmd": "reboot"})"),
            "unknown verb \"reboot\"; verbs: status, start, stop, scan");
  EXPECT_EQ(error_of(R"({"cmd": "start", "force": true})"),
            "unexpected member \"force\" in a \"start\" command");
  EXPECT_EQ(error_of(R"({"cmd": "scan"})").rfind("a scan command needs a \"scan\" object", 0), 0u);
  EXPECT_EQ(error_of(R"({"cmd": "scan", "scan": 3})").rfind("a scan command needs", 0), 0u);
  EXPECT_EQ(error_of(std::string(kMaxControlLineBytes + 1, ' ')), "line longer than 4096 bytes");
  const auto with_id = parse_control_line(R"({"cmd": "nope", "id": "abc"})");
  EXPECT_EQ(std::get<ControlParseError>(with_id).id, "abc");
}

// Issue F8: a key given twice must not let the last one decide ({"cmd":"stop","cmd":"start"}
// used to arm the laser); it is an error at any depth.
TEST(ControlProtocol, DuplicateKeysAreRefused) {
  EXPECT_EQ(error_of(R"({"cmd":"stop","cmd":"start"})"),
            "key \"cmd\" given twice in one object; each key once");
  EXPECT_EQ(error_of(R"({"cmd":"scan","scan":{"pattern":"radial","pattern":"raster"}})"),
            "key \"pattern\" given twice in one object; each key once");
  EXPECT_EQ(error_of(R"({"cmd":"status","id":1,"id":2})"),
            "key \"id\" given twice in one object; each key once");
  // The same key in different objects is fine.
  EXPECT_EQ(error_of(R"({"cmd":"scan","scan":{"cmd":"x"}})").find("given twice"),
            std::string::npos);
}

// Issue F11: a blank line is answered too, with an error that says so.
TEST(ControlProtocol, BlankLinesGetAnError) {
  EXPECT_EQ(error_of(""), "empty line: expected one JSON object, like {\"cmd\": \"status\"}");
  EXPECT_EQ(error_of(" \t"), "empty line: expected one JSON object, like {\"cmd\": \"status\"}");
}

std::string scan_error(const std::string& changes) {
  try {
    apply_scan_changes(scan::ScanSpec{}, nlohmann::json::parse(changes));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "ok";
}

TEST(ControlProtocol, ScanChangesApplyOverTheCurrentSpecAndAreValidated) {
  scan::ScanSpec base;
  base.extent_x = 0.5;
  const scan::ScanSpec s = apply_scan_changes(
      base, nlohmann::json::parse(R"({"pattern": "radial", "rotation_deg": 30, "repeats": 2})"));
  EXPECT_EQ(s.kind, scan::ScanKind::radial);
  EXPECT_EQ(s.rotation_deg, 30.0);
  EXPECT_EQ(s.repeats, 2u);
  EXPECT_EQ(s.extent_x, 0.5) << "unchanged keys keep the current value";

  EXPECT_EQ(scan_error(R"({"extent_x": 3})"), "scan.extent_x = 3: must be in [0, 1]");
  EXPECT_EQ(scan_error(R"({"extent_x": "big"})"), "scan.extent_x = \"big\": must be a number");
  EXPECT_EQ(scan_error(R"({"repeats": -1})"), "scan.repeats = -1: must be in [1, 65536]");
  EXPECT_EQ(scan_error(R"({"repeats": 2.5})"), "scan.repeats = 2.5: must be an integer");
  EXPECT_EQ(scan_error(R"({"repeats": 1e30})"), "scan.repeats = 1e+30: must be an integer");
  EXPECT_EQ(scan_error(R"({"pattern": "spiral"})"),
            "scan.pattern = \"spiral\": must be one of raster, bidirectional, crosshair, radial");
  EXPECT_EQ(scan_error(R"({"bscans_per_volume": 64})")
                .rfind("scan.bscans_per_volume = 64: is fixed by the ring's geometry", 0),
            0u);
  EXPECT_EQ(scan_error(R"({"zoom": 2})").rfind("scan.zoom = 2: unknown scan key", 0), 0u);
}

TEST(ControlProtocol, ErrorRepliesAreOneJsonLine) {
  const std::string reply = error_reply("bad \"thing\"\n", 3, "scan");
  EXPECT_EQ(reply.find('\n'), std::string::npos);
  const nlohmann::json parsed = nlohmann::json::parse(reply);
  EXPECT_EQ(parsed["ok"], false);
  EXPECT_EQ(parsed["error"], "bad \"thing\"\n");
  EXPECT_EQ(parsed["id"], 3);
  EXPECT_EQ(parsed["cmd"], "scan");
}

}  // namespace
}  // namespace ioct::rt
