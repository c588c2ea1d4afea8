// The configuration file: the sample configs load and validate, every kind of mistake is refused
// with the key, the value, what is allowed and file:line, unknown keys are refused, and flags
// given on the command line override the file.
#include "rt_config.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "effective_config.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/scan/scan_infeasible.hpp"
#include "ioct/test_support/temp_path.hpp"
#include "rt_keys.hpp"
#include "rt_options.hpp"

namespace ioct::rt {
namespace {

std::string sample_config(const std::string& name) {
  return std::string(IOCT_RT_CONFIG_DIR) + "/" + name;
}

// The message load_config_text() or validate() gives for `text`, or "ok".
std::string error_for(const std::string& text) {
  RtConfig config;
  try {
    load_config_text(text, "bad.toml", config);
    config.validate();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "ok";
}

TEST(RtConfig, TheSampleConfigsLoadAndValidateAndTheirScansAreFeasible) {
  for (const char* name : {"simulator.toml", "paper-100khz.toml", "bench.toml"}) {
    SCOPED_TRACE(name);
    RtOptions options;
    options.config = sample_config(name);
    RtSetup setup;
    ASSERT_NO_THROW(setup = make_setup(options));
    setup.config.validate();
  }
}

// The simulator's sample lists every key with its default: it cannot drift from the declarations.
TEST(RtConfig, TheSimulatorSampleSetsEveryKeyToItsDefault) {
  RtConfig from_file;
  KeyPositions where;
  load_config_file(sample_config("simulator.toml"), from_file, &where);
  for (const config::KeySpec& key : rt_keys().specs()) {
    EXPECT_EQ(where.count(key.key), 1u) << key.key << " is not in rt/config/simulator.toml";
  }
  EXPECT_EQ(rt_keys().to_toml(from_file), rt_keys().to_toml(RtConfig{}));
}

// docs/config-keys.md holds the table `ioct-rt --config-keys` prints, as it is now.
TEST(RtConfig, TheDocsKeyTableIsTheDeclarations) {
  std::ifstream in(IOCT_DOCS_DIR "/config-keys.md");
  ASSERT_TRUE(in) << IOCT_DOCS_DIR "/config-keys.md";
  const std::string docs((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(docs.find(rt_keys().markdown()), std::string::npos)
      << "regenerate the ioct-rt table of docs/config-keys.md with ioct-rt --config-keys";
}

TEST(RtConfig, ThePaperConfigIsThePapersSystem) {
  RtConfig c;
  load_config_file(sample_config("paper-100khz.toml"), c);
  EXPECT_EQ(c.digitizer.ascan_rate_hz, 100'000.0);
  EXPECT_EQ(c.digitizer.samples_per_ascan, 1376u);
  EXPECT_EQ(c.digitizer.ascans_per_bscan, 512u);
  EXPECT_EQ(c.bscans_per_volume, 128u);
  EXPECT_EQ(c.digitizer.bscans_per_group, 16u);
}

TEST(RtConfig, ValuesOutOfRangeNameKeyValueRangeAndLine) {
  const std::string e = error_for("[digitizer]\nsamples_per_ascan = 1376\nascans_per_bscan = 0\n");
  EXPECT_EQ(e, "bad.toml:3:20: digitizer.ascans_per_bscan = 0: must be in [1, 65536]");
  EXPECT_EQ(error_for("[ring]\nslots = -3\n"),
            "bad.toml:2:9: ring.slots = -3: must be in [2, 4096]");
  EXPECT_EQ(error_for("[realtime]\npriority = 100\n"),
            "bad.toml:2:12: realtime.priority = 100: must be in [0, 99]");
}

TEST(RtConfig, SimulationWorkersAreAutoOrACount) {
  RtConfig config;
  EXPECT_EQ(config.simulation_workers, -1) << "absent: auto";
  EXPECT_GE(config.resolved_simulation_workers(), 1u);
  load_config_text("[simulation]\nworkers = 0\n", "w.toml", config);
  EXPECT_EQ(config.resolved_simulation_workers(), 0u) << "0: synthesis on the acquisition thread";
  load_config_text("[simulation]\nworkers = 6\n", "w.toml", config);
  EXPECT_EQ(config.resolved_simulation_workers(), 6u);
  load_config_text("[simulation]\nworkers = \"auto\"\n", "w.toml", config);
  EXPECT_EQ(config.simulation_workers, -1);
  EXPECT_EQ(error_for("[simulation]\nworkers = 65\n"),
            "bad.toml:2:11: simulation.workers = 65: must be \"auto\" or an integer in [0, 64]");
  EXPECT_EQ(error_for("[simulation]\nworkers = \"many\"\n"),
            "bad.toml:2:11: simulation.workers = \"many\": must be \"auto\" or an integer in [0, "
            "64]");
  EXPECT_EQ(error_for("[simulation]\nworkers = 1.5\n"),
            "bad.toml:2:11: simulation.workers = 1.5: must be an integer, not a number");
}

TEST(RtConfig, WrongTypesAreRefused) {
  EXPECT_EQ(error_for("[scan]\nextent_x = \"wide\"\n"),
            "bad.toml:2:12: scan.extent_x = \"wide\": must be a number, not a string");
  EXPECT_EQ(error_for("[control]\nstart_scanning = 1\n"),
            "bad.toml:2:18: control.start_scanning = 1: must be true or false, not an integer");
  EXPECT_EQ(error_for("digitizer = 3\n"),
            "bad.toml:1:13: digitizer = 3: must be a table, not an integer");
  EXPECT_EQ(error_for("[scan]\npattern = \"spiral\"\n"),
            "bad.toml:2:11: scan.pattern = \"spiral\": must be one of raster, bidirectional, "
            "crosshair, radial");
}

TEST(RtConfig, UnknownKeysAndTablesAreRefused) {
  const std::string e = error_for("[scan]\nextent_x = 0.5\nextnt_y = 0.5\n");
  EXPECT_EQ(e.rfind("bad.toml:3:1: scan.extnt_y: unknown key; [scan] takes pattern, ", 0), 0u) << e;
  const std::string t = error_for("[scanner]\nx = 1\n");
  EXPECT_EQ(t.rfind("bad.toml:1:2: scanner: unknown key; the file takes ring, digitizer", 0), 0u)
      << t;
  const std::string n = error_for("[lines.laser_emission]\noffset = 3\npolarity = 1\n");
  EXPECT_EQ(n.rfind("bad.toml:3:1: lines.laser_emission.polarity: unknown key", 0), 0u) << n;
}

TEST(RtConfig, SyntaxErrorsSayWhere) {
  const std::string e = error_for("[ring]\nname = \"unterminated\n");
  EXPECT_EQ(e.rfind("bad.toml:2:", 0), 0u) << e;
  EXPECT_NE(e.find("not valid TOML"), std::string::npos) << e;
}

TEST(RtConfig, CrossChecksNameTheKey) {
  EXPECT_EQ(error_for("[realtime]\npriority = 80\nsafety_priority = 70\n"),
            "realtime.safety_priority = 70: must be above realtime.priority = 80: the safety "
            "thread preempts the acquisition thread");
  const std::string fifo = error_for("[galvo]\nfifo_capacity = 1000\n");
  EXPECT_EQ(
      fifo.rfind("galvo.fifo_capacity = 1000: must hold more than one group of sweeps (8608)", 0),
      0u)
      << fifo;
  EXPECT_EQ(error_for("[lines]\nlaser_emission = { offset = 4 }\n"),
            "lines.k_clock_valid.offset = 4: is already used by lines.laser_emission.offset");
  EXPECT_EQ(error_for("[digitizer]\nsamples_per_ascan = 1377\n")
                .rfind("digitizer.samples_per_ascan = 1377: must be even", 0),
            0u);
}

// A configuration file for one test.
test_support::TempPath config_file(const std::string& text) {
  return test_support::TempPath::with_text("rt-config", ".toml", text);
}

TEST(RtConfig, SemanticErrorsFromTheFileCarryItsLineAndFlagsOverrideTheFile) {
  const auto file = config_file(
      "[scan]\nbscans_per_volume = 100\n[digitizer]\nbscans_per_group = 16\n"
      "[galvo]\nmax_acceleration = 1e8\n");
  RtOptions options;
  options.config = file.str();
  try {
    make_setup(options);
    FAIL() << "accepted";
  } catch (const ConfigFileError& e) {
    // The infeasible flyback is refused at the line of the limit it violates.
    EXPECT_EQ(std::string(e.what()).rfind(file.str() + ":6:20: scan infeasible: ", 0), 0u)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("galvo.max_acceleration"), std::string::npos);
  }
  // A flag overrides the file's key: the same file with --flyback 40 is feasible.
  options.set("digitizer.flyback_sweeps", "40");
  const RtSetup setup = make_setup(options);
  EXPECT_EQ(setup.config.digitizer.flyback_sweeps, 40u);
  EXPECT_EQ(setup.config.bscans_per_volume, 100u) << "from the file";
  EXPECT_EQ(setup.ring.geometry.bscans_per_volume, 100u);
  EXPECT_EQ(setup.config.digitizer.samples_per_ascan, 1376u) << "neither in the file nor a flag";
}

TEST(RtConfig, SimulatedInstrumentsComeFromTheFileOrTheFlagAndBadOnesAreLocated) {
  const auto file = config_file(
      "[simulation]\ninstruments = [\"forceps:x=0.1,depth=0.3,tremor-depth=0.05,tremor-hz=0.1\", "
      "\"needle:y=-0.2\"]\n");
  RtOptions options;
  options.config = file.str();
  const RtSetup setup = make_setup(options);
  ASSERT_EQ(setup.simulation.instruments.size(), 2u);
  EXPECT_EQ(setup.simulation.instruments[0].kind, sim::InstrumentKind::forceps);
  EXPECT_FLOAT_EQ(setup.simulation.instruments[0].pose.tip_x, 0.1f);
  EXPECT_FLOAT_EQ(setup.simulation.instruments[0].pose.tip_depth_fraction, 0.3f);
  EXPECT_FLOAT_EQ(setup.simulation.instruments[0].motion.tremor_depth, 0.05f);
  EXPECT_FLOAT_EQ(setup.simulation.instruments[0].motion.tremor_hz, 0.1f);
  EXPECT_EQ(setup.simulation.instruments[1].kind, sim::InstrumentKind::needle);
  EXPECT_FLOAT_EQ(setup.simulation.instruments[1].pose.tip_y, -0.2f);

  // --sim-instrument replaces the file's list.
  options.overrides["simulation.instruments"] = {"scraper:x=0.3"};
  const RtSetup flagged = make_setup(options);
  ASSERT_EQ(flagged.simulation.instruments.size(), 1u);
  EXPECT_EQ(flagged.simulation.instruments[0].kind, sim::InstrumentKind::scraper);

  // A bad item in the file is refused at the list's line, naming the item and what is allowed.
  const auto bad = config_file("[simulation]\nseed = 3\ninstruments = [\"tweezers:x=0\"]\n");
  options.config = bad.str();
  options.overrides.clear();
  try {
    make_setup(options);
    FAIL() << "accepted";
  } catch (const ConfigFileError& e) {
    EXPECT_EQ(std::string(e.what()), bad.str() +
                                         ":3:15: simulation.instruments[0] = 'tweezers': must "
                                         "start with forceps, needle or scraper")
        << e.what();
  }
  const auto range = config_file("[simulation]\ninstruments = [\"needle:pitch=120\"]\n");
  options.config = range.str();
  try {
    make_setup(options);
    FAIL() << "accepted";
  } catch (const ConfigFileError& e) {
    EXPECT_NE(std::string(e.what()).find("simulation.instruments[0].pose.pitch_deg = 120"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(error_for("[simulation]\ninstruments = \"needle\"\n"),
            "bad.toml:2:15: simulation.instruments = \"needle\": must be an array of strings, not "
            "a string");
  EXPECT_NE(error_for("[simulation]\ninstruments = [\"needle\", \"needle\", \"needle\", "
                      "\"needle\", \"needle\"]\n")
                .find("simulation.instruments = 5 items: must have at most 4"),
            std::string::npos);
}

TEST(RtConfig, AFlagsBadValueIsReportedAgainstTheFlag) {
  const auto error_of = [](const std::string& key, const std::string& text) {
    RtOptions options;
    options.set(key, text);
    try {
      make_setup(options);
    } catch (const ConfigError& e) {
      return std::make_pair(std::string(e.what()), option_for_key(e.key()));
    }
    return std::make_pair(std::string("accepted"), std::string());
  };
  EXPECT_EQ(error_of("digitizer.samples_per_ascan", "7"),
            std::make_pair(std::string("digitizer.samples_per_ascan = 7: must be in [16, 16384]"),
                           std::string("--samples")));
  EXPECT_EQ(error_of("digitizer.samples_per_ascan", "12x"),
            std::make_pair(std::string("digitizer.samples_per_ascan = \"12x\": must be an "
                                       "integer in [16, 16384]"),
                           std::string("--samples")));
  EXPECT_EQ(error_of("scan.pattern", "zigzag"),
            std::make_pair(std::string("scan.pattern = \"zigzag\": must be one of raster, "
                                       "bidirectional, crosshair, radial"),
                           std::string("--pattern")));
  EXPECT_EQ(error_of("status.interval_s", "nan").second, "--status-interval");
  // A key only a product of flags sets is looked up as well.
  EXPECT_EQ(option_for_key("digitizer.samples_per_group"),
            "--samples x --ascans x --bscans-per-group");
  EXPECT_EQ(option_for_key("galvo.max_velocity"), "") << "set in the file only";
  // What the ring itself would refuse is refused under its key first.
  EXPECT_EQ(error_of("digitizer.bscans_per_group", "65"),
            std::make_pair(std::string("digitizer.bscans_per_group = 65: must be in [1, 64]"),
                           std::string("--bscans-per-group")));
  EXPECT_EQ(error_of("ring.name", "a/b").second, "--ring");
}

TEST(RtConfig, APartsOwnCheckOfAFileKeyIsPlacedAtItsLine) {
  const auto located = [](const std::string& text) {
    const auto file = config_file(text);
    RtOptions options;
    options.config = file.str();
    try {
      make_setup(options);
    } catch (const std::exception& e) {
      const std::string what = e.what();
      return what.rfind(file.str(), 0) == 0 ? what.substr(file.str().size()) : what;
    }
    return std::string("accepted");
  };
  EXPECT_EQ(located("[galvo]\npark_x = 2.0\n"), ":2:10: galvo.park_x = 2: must be in [-1, 1]");
  EXPECT_EQ(located("[ring]\nname = \"a/b\"\n").rfind(":2:8: ring.name = \"a/b\": ", 0), 0u)
      << located("[ring]\nname = \"a/b\"\n");
}

TEST(RtConfig, ReplaySpeedIsAPositiveMultipleAndOnlyForAReplay) {
  for (const double bad : {0.0, -2.0, 1001.0, std::nan("")}) {
    RtOptions options;
    options.replay = "run.h5";
    options.replay_speed = bad;
    try {
      make_setup(options);
      FAIL() << "--replay-speed " << bad << " was accepted";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), "replay-speed");
      EXPECT_NE(std::string(e.what()).find("(0, 1000]"), std::string::npos) << e.what();
    }
  }
  RtOptions live;
  live.replay_speed = 2.0;
  try {
    make_setup(live);
    FAIL() << "--replay-speed without --replay was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("--replay FILE"), std::string::npos) << e.what();
  }
  RtOptions fast;
  fast.replay = "run.h5";
  fast.replay_speed = 8.0;
  EXPECT_EQ(make_setup(fast).replay_speed, 8.0);
}

}  // namespace
}  // namespace ioct::rt

namespace ioct::rt {
namespace {

std::string file_error_for(const std::string& path) {
  RtConfig config;
  try {
    load_config_file(path, config);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "ok";
}

// Issue F7: an empty file, or one with nothing but comments, is refused rather than run on
// defaults; so is a file cut off inside a line.
TEST(RtConfigSafety, EmptyAndCutOffFilesAreRefused) {
  const auto empty = config_file("");
  EXPECT_NE(file_error_for(empty.str()).find("the configuration is empty"), std::string::npos)
      << file_error_for(empty.str());
  const auto comments = config_file("# a header comment\n\n");
  EXPECT_NE(file_error_for(comments.str()).find("the configuration is empty"), std::string::npos);
  const auto cut = config_file("[ring]\nname = \"x\"\n[control]\nstart_scan");
  const std::string message = file_error_for(cut.str());
  EXPECT_NE(message.find(cut.str() + ":4:1: the file does not end with a newline"),
            std::string::npos)
      << message;
}

// Issue F7: with a real backend every safety-relevant key must be in the file: a hardware file
// cut before [control] names what it lacks instead of arming the laser with no control socket.
TEST(RtConfigSafety, HardwareFileMustSetEverySafetyKey) {
  std::ifstream in(sample_config("paper-100khz.toml"));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto control = text.find("[control]");
  ASSERT_NE(control, std::string::npos);
  const auto cut = config_file(text.substr(0, control));
  const std::string message = file_error_for(cut.str());
  EXPECT_NE(message.find("with real hardware (digitizer.backend = \"usb\")"), std::string::npos)
      << message;
  for (const char* key : {"control.socket", "control.start_scanning", "control.max_clients"}) {
    EXPECT_NE(message.find(key), std::string::npos) << key << ": " << message;
  }
  EXPECT_EQ(message.find("galvo.max_velocity"), std::string::npos) << "it is in the file";

  // Each key on its own: leaving out any one is refused.
  for (const char* key : kSafetyKeysOnHardware) {
    SCOPED_TRACE(key);
    const std::string name = std::string(key).substr(std::string(key).find('.') + 1);
    const auto at = text.find("\n" + name + " = ");
    ASSERT_NE(at, std::string::npos) << "the paper config sets " << key;
    const auto end = text.find('\n', at + 1);
    const auto without = config_file(text.substr(0, at) + text.substr(end));
    EXPECT_NE(file_error_for(without.str()).find(key), std::string::npos)
        << file_error_for(without.str());
  }
  // The simulator needs none of them.
  EXPECT_EQ(error_for("[digitizer]\nbackend = \"simulated\"\n"), "ok");
}

// Issue F6: a FIFO or a device as the configuration is refused at once (a FIFO used to block
// the open, /dev/zero to grow memory without end).
TEST(RtConfigSafety, ConfigMustBeARegularFileOfBoundedSize) {
  const std::string fifo = std::filesystem::temp_directory_path() /
                           ("ioct-rt-config-fifo-" + std::to_string(::getpid()));
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // Opened non-blocking: this returns at once (a blocking open would hang the test here).
  EXPECT_NE(file_error_for(fifo).find("it is a FIFO, not a regular file"), std::string::npos)
      << file_error_for(fifo);
  std::filesystem::remove(fifo);
  EXPECT_NE(file_error_for("/dev/zero").find("it is a character device"), std::string::npos)
      << file_error_for("/dev/zero");
  const auto huge = config_file(std::string(kMaxConfigBytes + 1, '#'));
  EXPECT_NE(file_error_for(huge.str()).find("more than the"), std::string::npos);
}

// --check-config prints the effective configuration; it reads back as the same configuration.
TEST(RtConfigSafety, EffectiveConfigReadsBackAsTheSameConfig) {
  RtConfig original;
  load_config_file(sample_config("paper-100khz.toml"), original);
  const std::string printed = effective_config_toml(original);
  RtConfig reread;
  ASSERT_NO_THROW(load_config_text(printed, "printed", reread)) << printed;
  EXPECT_EQ(effective_config_toml(reread), printed);
  EXPECT_FALSE(reread.start_scanning);
  EXPECT_EQ(reread.control_socket, "/run/ioct/rt.sock");
}

}  // namespace
}  // namespace ioct::rt
