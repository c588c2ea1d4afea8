// KeyTable on a small config of its own: every way a key is set (file, flag) or shown (printed
// TOML, help, Markdown) goes through the one declaration, and what is wrong is named with its key
// and, for a file, its line and column.
#include "ioct/config/key_table.hpp"

#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace ioct::config {
namespace {

enum class Shape { round, square };

struct Probe {
  std::string name = "probe";
  std::uint32_t slots = 8;
  double gain = 1.5;
  std::int64_t workers = -1;
  bool verbose = false;
  bool stages = true;
  std::string backend = "cpu";
  Shape shape = Shape::round;
  std::uint16_t offset = 3;
  std::vector<std::string> tags;
};

#define MEMBER(m)        \
  [](auto& c) -> auto& { \
    return c.m;          \
  }

KeyTable<Probe> probe_keys() {
  KeyTable<Probe> k;
  k.text("name", MEMBER(name), "what it is called", "--name")
      .text_list("tags", MEMBER(tags), "labels", "--tag")
      .integer("ring.slots", MEMBER(slots), 2, 64, "slots in the ring", "--slots")
      .real_in("ring.gain", MEMBER(gain), 0.5, 4.0, "gain", "--gain")
      .integer_or_auto("ring.workers", MEMBER(workers), 0, 16, "threads", "--workers")
      .boolean("ring.verbose", MEMBER(verbose), "say more", "--verbose")
      .boolean("ring.stages", MEMBER(stages), "run the stages", "--no-stages")
      .choice("ring.backend", MEMBER(backend), {"cpu", "cuda"}, "where it runs", "--backend")
      .choice_of(
          "ring.shape", {"round", "square"},
          [](const Probe& p) { return std::string(p.shape == Shape::round ? "round" : "square"); },
          [](Probe& p, const std::string& v) {
            p.shape = v == "round" ? Shape::round : Shape::square;
          },
          "its shape")
      .integer("ring.line.offset", MEMBER(offset), 0, 1023, "GPIO offset");
  return k;
}

std::string error_reading(const std::string& text) {
  Probe p;
  try {
    probe_keys().read_text(text, "p.toml", p);
  } catch (const ConfigFileError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(KeyTable, ReadsEachKindFromTheFileAndLeavesAbsentKeysAlone) {
  Probe p;
  KeyPositions where;
  probe_keys().read_text(
      "name = \"bench\"\ntags = [\"a\", \"b\"]\n[ring]\nslots = 16\ngain = 2\nworkers = \"auto\"\n"
      "verbose = true\nbackend = \"cuda\"\nshape = \"square\"\nline = { offset = 7 }\n",
      "p.toml", p, &where);
  EXPECT_EQ(p.name, "bench");
  EXPECT_EQ(p.slots, 16u);
  EXPECT_EQ(p.gain, 2.0) << "an integer where a number goes";
  EXPECT_EQ(p.workers, -1);
  EXPECT_TRUE(p.verbose);
  EXPECT_TRUE(p.stages) << "absent: unchanged";
  EXPECT_EQ(p.backend, "cuda");
  EXPECT_EQ(p.shape, Shape::square);
  EXPECT_EQ(p.offset, 7u);
  EXPECT_EQ(p.tags, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(where.at("ring.slots").line, 4u);
  EXPECT_EQ(where.at("ring.line.offset").line, 10u);
}

TEST(KeyTable, AFilesErrorNamesFileLineColumnKeyValueAndWhatIsAllowed) {
  EXPECT_EQ(error_reading("[ring]\nslots = 65\n"),
            "p.toml:2:9: ring.slots = 65: must be in [2, 64]");
  EXPECT_EQ(error_reading("[ring]\ngain = 9.5\n"),
            "p.toml:2:8: ring.gain = 9.5: must be in [0.5, 4]");
  EXPECT_EQ(error_reading("[ring]\nworkers = \"many\"\n"),
            "p.toml:2:11: ring.workers = \"many\": must be \"auto\" or an integer in [0, 16]");
  EXPECT_EQ(error_reading("[ring]\nworkers = -1\n"),
            "p.toml:2:11: ring.workers = -1: must be \"auto\" or an integer in [0, 16]")
      << "-1 is how the member keeps auto, not a count";
  EXPECT_EQ(error_reading("[ring]\nslots = 1.5\n"),
            "p.toml:2:9: ring.slots = 1.5: must be an integer, not a number");
  EXPECT_EQ(error_reading("[ring]\nbackend = \"tpu\"\n"),
            "p.toml:2:11: ring.backend = \"tpu\": must be one of cpu, cuda");
  EXPECT_EQ(error_reading("tags = \"a\"\n"),
            "p.toml:1:8: tags = \"a\": must be an array of strings, not a string");
  EXPECT_EQ(error_reading("ring = 3\n"), "p.toml:1:8: ring = 3: must be a table, not an integer");
  EXPECT_EQ(error_reading("[ring]\nslotz = 3\n"),
            "p.toml:2:1: ring.slotz: unknown key; [ring] takes slots, gain, workers, verbose, "
            "stages, backend, shape, line");
  EXPECT_EQ(error_reading("[rings]\n"),
            "p.toml:1:2: rings: unknown key; the file takes name, tags, ring");
  EXPECT_EQ(error_reading("[ring.line]\npolarity = 1\n"),
            "p.toml:2:1: ring.line.polarity: unknown key; [ring.line] takes offset");
  EXPECT_EQ(error_reading("# nothing\n"),
            "p.toml:2:1: the configuration is empty (no table, no key): refusing it rather than "
            "running on defaults");
  EXPECT_EQ(error_reading("[ring]\nslots = \n").rfind("p.toml:2:", 0), 0u);
  // A quoted key with a dot is not the key its text spells: refused, never ignored.
  EXPECT_EQ(error_reading("\"ring.slots\" = 4\n"),
            "p.toml:1:1: ring.slots: unknown key; the file takes name, tags, ring");
  EXPECT_EQ(error_reading("[ring]\n\"line.offset\" = 4\n")
                .rfind("p.toml:2:1: ring.line.offset: "
                       "unknown key; [ring] takes",
                       0),
            0u);
}

TEST(KeyTable, TheRangesAreCheckedOnAConfigFilledInCode) {
  const KeyTable<Probe> keys = probe_keys();
  Probe p;
  EXPECT_NO_THROW(keys.check_ranges(p));
  p.slots = 1;
  try {
    keys.check_ranges(p);
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "ring.slots");
    EXPECT_STREQ(e.what(), "ring.slots = 1: must be in [2, 64]");
  }
  p = Probe{};
  p.backend = "tpu";
  EXPECT_THROW(keys.check_ranges(p), ConfigError);
}

TEST(KeyTable, FlagsGoThroughTheCommandLineToTheirKeysAndAreCheckedAlike) {
  const KeyTable<Probe> keys = probe_keys();
  CLI::App app;
  Overrides overrides;
  keys.add_flags_to(app, overrides);
  std::vector<std::string> args{"--tag", "y",      "--tag", "x",       "--no-stages", "--workers",
                                "auto",  "--gain", "2.5",   "--slots", "12"};
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  app.parse(args);
  Probe p;
  keys.apply(overrides, p);
  EXPECT_EQ(p.slots, 12u);
  EXPECT_EQ(p.gain, 2.5);
  EXPECT_EQ(p.workers, -1);
  EXPECT_FALSE(p.stages) << "--no-stages sets its key false";
  EXPECT_EQ(p.tags, (std::vector<std::string>{"y", "x"}));
  EXPECT_EQ(overrides.count("ring.verbose"), 0u) << "only the flags given";

  // A boolean flag's explicit value is its value; "--no-x=false" means x.
  CLI::App explicit_values;
  Overrides given;
  keys.add_flags_to(explicit_values, given);
  std::vector<std::string> values{"--verbose=false", "--no-stages=false"};
  std::reverse(values.begin(), values.end());
  explicit_values.parse(values);
  p = Probe{};
  p.verbose = true;
  p.stages = false;
  keys.apply(given, p);
  EXPECT_FALSE(p.verbose);
  EXPECT_TRUE(p.stages);

  const auto error_for = [&](const std::string& key, const std::string& text) {
    try {
      keys.apply({{key, {text}}}, p);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(error_for("ring.slots", "12x"), "ring.slots = \"12x\": must be an integer in [2, 64]");
  EXPECT_EQ(error_for("ring.slots", "99"), "ring.slots = 99: must be in [2, 64]");
  EXPECT_EQ(error_for("ring.gain", "inf"), "ring.gain = \"inf\": must be a finite number");
  EXPECT_EQ(error_for("ring.backend", "tpu"), "ring.backend = \"tpu\": must be one of cpu, cuda");
  EXPECT_EQ(error_for("name", "bad \xff byte"), "name = \"bad \\xff byte\": must be UTF-8 text");
  EXPECT_EQ(keys.flag_for("ring.slots"), "--slots");
  EXPECT_EQ(keys.flag_for("ring.shape"), "");
  EXPECT_NE(app.help().find("ring.slots: slots in the ring"), std::string::npos) << app.help();
}

TEST(KeyTable, ThePrintedConfigurationReadsBackAsTheSame) {
  const KeyTable<Probe> keys = probe_keys();
  Probe p;
  p.name = "a \"quoted\" \\ name\twith a tab";
  p.gain = 3.0;
  p.workers = 4;
  p.shape = Shape::square;
  p.tags = {"forceps:x=0.1", "needle"};
  const std::string printed = keys.to_toml(p);
  EXPECT_NE(printed.find("gain = 3.0\n"), std::string::npos) << printed;
  EXPECT_NE(printed.find("[ring.line]\noffset = 3\n"), std::string::npos) << printed;
  Probe again;
  keys.read_text(printed, "printed", again);
  EXPECT_EQ(keys.to_toml(again), printed);
  EXPECT_EQ(again.name, p.name);
  EXPECT_EQ(again.tags, p.tags);
}

TEST(KeyTable, TheMarkdownTableHasARowPerKeyWithItsFlagRangeAndDefault) {
  const std::string table = probe_keys().markdown();
  EXPECT_NE(table.find("| `ring.slots` | `--slots` | in [2, 64] | `8` | slots in the ring |"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("| `ring.shape` |  | one of round, square | `\"round\"` | its shape |"),
            std::string::npos)
      << table;
  KeyTable<Probe> barred;
  barred.text("name", MEMBER(name), "a | b");
  EXPECT_NE(barred.markdown().find("| a \\| b |"), std::string::npos)
      << "a bar in a cell is escaped: " << barred.markdown();
}

TEST(KeyTable, AMistakeInTheDeclarationsIsCaughtBeforeAnyFileIsRead) {
  KeyTable<Probe> twice = probe_keys();
  twice.integer("ring.slots", MEMBER(slots), 2, 64, "again");
  Probe p;
  EXPECT_THROW(twice.read_text("name = \"x\"\n", "p.toml", p), std::logic_error);
  KeyTable<Probe> apart = probe_keys();
  apart.integer("ring.more", MEMBER(slots), 2, 64, "after [ring.line]");
  EXPECT_THROW(apart.read_text("name = \"x\"\n", "p.toml", p), std::logic_error)
      << "[ring]'s keys split: the printed file would define [ring] twice";
  KeyTable<Probe> late_top = probe_keys();
  late_top.text("late", MEMBER(name), "after the tables");
  EXPECT_THROW(late_top.read_text("name = \"x\"\n", "p.toml", p), std::logic_error)
      << "it would print inside the last table";
  KeyTable<Probe> same_flag = probe_keys();
  same_flag.integer("other", MEMBER(slots), 2, 64, "x", "--slots");
  CLI::App app;
  Overrides o;
  EXPECT_THROW(same_flag.add_flags_to(app, o), std::logic_error);
}

}  // namespace
}  // namespace ioct::config
