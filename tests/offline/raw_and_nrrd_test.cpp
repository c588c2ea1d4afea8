// Raw spectra files (sizes, byte order), NRRD files (round trip, what the reader refuses), the
// progress bar.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/offline/calibration_file.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"
#include "ioct/gpu/offline/nrrd_file.hpp"
#include "ioct/gpu/offline/progress_bar.hpp"
#include "ioct/gpu/offline/raw_spectra_file.hpp"
#include "ioct/test_support/bounded_child.hpp"
#include "ioct/test_support/sanitizer_build.hpp"
#include "offline_test_support.hpp"

namespace ioct::gpu::offline {
namespace {

using testing::ScratchDir;

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no exception)";
}

TEST(ByteOrder, LittleOrBigAndNothingElse) {
  EXPECT_EQ(parse_byte_order("little"), ByteOrder::little);
  EXPECT_EQ(parse_byte_order("big"), ByteOrder::big);
  for (const char* bad : {"middle", "LE", "", "Little"}) {
    EXPECT_THROW(parse_byte_order(bad), ConfigError) << bad;
  }
  EXPECT_NE(message_of([] { parse_byte_order("middle"); }).find("byte_order = 'middle'"),
            std::string::npos);
}

RawSpectraLayout small_layout() {
  RawSpectraLayout layout;
  layout.samples_per_ascan = 16;
  layout.ascans_per_bscan = 3;
  layout.bscans = 4;
  return layout;
}

std::vector<std::uint16_t> counting(std::size_t n) {
  std::vector<std::uint16_t> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::uint16_t>(i * 257 + 3);
  return v;
}

TEST(RawSpectraFile, ReadsBscansInEitherByteOrder) {
  ScratchDir dir;
  RawSpectraLayout layout = small_layout();
  const auto values = counting(4 * 3 * 16);
  testing::write_u16_file(dir / "le.raw", values, true);
  testing::write_u16_file(dir / "be.raw", values, false, 10);
  const RawSpectraFile little(dir / "le.raw", layout);
  layout.byte_order = ByteOrder::big;
  layout.header_bytes = 10;
  const RawSpectraFile big(dir / "be.raw", layout);
  std::vector<std::uint16_t> a(2 * 3 * 16), b(2 * 3 * 16);
  little.read_bscans(1, 2, a);
  big.read_bscans(1, 2, b);
  const std::vector<std::uint16_t> expected(values.begin() + 48, values.begin() + 48 + 96);
  EXPECT_EQ(a, expected);
  EXPECT_EQ(b, expected);
  EXPECT_THROW(little.read_bscans(3, 2, a), std::out_of_range);
}

TEST(RawSpectraFile, RefusesAFileWhoseSizeDoesNotMatchTheDimensions) {
  ScratchDir dir;
  const RawSpectraLayout layout = small_layout();  // 4 x 3 x 16 x 2 = 384 bytes
  testing::write_u16_file(dir / "short.raw", counting(4 * 3 * 16 - 1), true);
  testing::write_u16_file(dir / "long.raw", counting(5 * 3 * 16), true);
  const std::string short_message = message_of([&] { RawSpectraFile(dir / "short.raw", layout); });
  EXPECT_NE(short_message.find("short.raw: truncated"), std::string::npos) << short_message;
  EXPECT_NE(short_message.find("382 bytes"), std::string::npos) << short_message;
  EXPECT_NE(short_message.find("need 384"), std::string::npos) << short_message;
  const std::string long_message = message_of([&] { RawSpectraFile(dir / "long.raw", layout); });
  EXPECT_NE(long_message.find("larger than its dimensions say"), std::string::npos) << long_message;
  EXPECT_NE(long_message.find("96 more"), std::string::npos) << long_message;
  EXPECT_THROW(RawSpectraFile(dir / "missing.raw", layout), InputFileError);
  EXPECT_NE(message_of([&] { RawSpectraFile(dir.path(), layout); }).find("not a regular file"),
            std::string::npos);
}

TEST(RawSpectraFile, RefusesLayoutsTheChainCannotProcess) {
  ScratchDir dir;
  testing::write_u16_file(dir / "x.raw", counting(64), true);
  RawSpectraLayout layout = small_layout();
  layout.samples_per_ascan = 15;
  EXPECT_THROW(RawSpectraFile(dir / "x.raw", layout), ConfigError);
  layout = small_layout();
  layout.bscans = 0;
  EXPECT_THROW(RawSpectraFile(dir / "x.raw", layout), ConfigError);
}

Volume numbered_volume(std::uint32_t b, std::uint32_t a, std::uint32_t d) {
  Volume volume(b, a, d);
  for (std::uint32_t z = 0; z < b; ++z) {
    auto pixels = volume.bscan(z);
    for (std::size_t i = 0; i < pixels.size(); ++i)
      pixels[i] = static_cast<std::uint8_t>(i * 7 + z);
  }
  return volume;
}

TEST(Nrrd, WritesTheDocumentedHeaderAndReadsItBack) {
  ScratchDir dir;
  const Volume volume = numbered_volume(3, 5, 7);
  NrrdMetadata metadata;
  metadata.spacings = {0.0039, 0.0117, std::nan("")};
  metadata.unit = "mm";
  metadata.content = "test volume";
  metadata.key_values = {{"ioct_backend", "cpu"}};
  write_nrrd_file(dir / "v.nrrd", volume, metadata);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"v.nrrd"});  // no temporary left

  const std::string text = testing::read_text(dir / "v.nrrd");
  const std::string header = text.substr(0, text.find("\n\n") + 2);
  EXPECT_EQ(header,
            "NRRD0004\n"
            "# ioct volume: u8 [bscan][ascan][depth], depth fastest\n"
            "type: uint8\n"
            "dimension: 3\n"
            "sizes: 7 5 3\n"
            "spacings: 0.0039 0.0117 nan\n"
            "units: \"mm\" \"mm\" \"mm\"\n"
            "kinds: domain domain domain\n"
            "labels: \"depth\" \"ascan\" \"bscan\"\n"
            "content: test volume\n"
            "encoding: raw\n"
            "ioct_backend:=cpu\n\n");
  EXPECT_EQ(text.size(), header.size() + 3 * 5 * 7);

  const NrrdVolume back = read_nrrd_file(dir / "v.nrrd");
  EXPECT_EQ(back.volume.bscans(), 3u);
  EXPECT_EQ(back.volume.ascans(), 5u);
  EXPECT_EQ(back.volume.depth(), 7u);
  for (std::uint32_t b = 0; b < 3; ++b) {
    EXPECT_TRUE(std::ranges::equal(back.volume.bscan(b), volume.bscan(b))) << b;
  }
  EXPECT_EQ(back.metadata.spacings[0], 0.0039);
  EXPECT_EQ(back.metadata.spacings[1], 0.0117);
  EXPECT_TRUE(std::isnan(back.metadata.spacings[2]));
  EXPECT_EQ(back.metadata.unit, "mm");
  EXPECT_EQ(back.metadata.content, "test volume");
  EXPECT_EQ(back.metadata.key_values, metadata.key_values);
}

TEST(Nrrd, AFailedWriteLeavesNoFile) {
  ScratchDir dir;
  NrrdMetadata bad;
  bad.spacings = {1, -1, 1};
  EXPECT_THROW(write_nrrd_file(dir / "v.nrrd", numbered_volume(1, 2, 3), bad),
               std::invalid_argument);
  bad.spacings = {1, 1, 1};
  bad.content = "two\nlines";
  EXPECT_THROW(write_nrrd_file(dir / "v.nrrd", numbered_volume(1, 2, 3), bad),
               std::invalid_argument);
  EXPECT_TRUE(dir.entries().empty());
  EXPECT_THROW(write_nrrd_file(dir / "no-such-dir" / "v.nrrd", numbered_volume(1, 2, 3), {}),
               std::runtime_error);
}

// A valid file with one header line replaced (or the data cut), and what the reader must say.
struct BadNrrd {
  std::string name;
  std::string from, to;  // header text replaced
  long data_delta;       // bytes added to (or cut from) the data
  std::string expected;  // part of the message
};

class NrrdReader : public ::testing::TestWithParam<BadNrrd> {};

TEST_P(NrrdReader, RefusesWithTheReason) {
  ScratchDir dir;
  write_nrrd_file(dir / "good.nrrd", numbered_volume(2, 3, 4), {});
  std::string text = testing::read_text(dir / "good.nrrd");
  const BadNrrd& bad = GetParam();
  if (!bad.from.empty()) {
    const auto at = text.find(bad.from);
    ASSERT_NE(at, std::string::npos) << bad.from;
    text.replace(at, bad.from.size(), bad.to);
  }
  if (bad.data_delta < 0) text.resize(text.size() + bad.data_delta);
  if (bad.data_delta > 0) text.append(static_cast<std::size_t>(bad.data_delta), 'x');
  testing::write_bytes(dir / "bad.nrrd", {text.begin(), text.end()});
  try {
    read_nrrd_file(dir / "bad.nrrd");
    FAIL() << "accepted: " << bad.name;
  } catch (const InputFileError& e) {
    EXPECT_NE(std::string(e.what()).find(bad.expected), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.nrrd"), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    BadFiles, NrrdReader,
    ::testing::Values(
        BadNrrd{"magic", "NRRD0004", "NRRD0009", 0, "not a NRRD file"},
        BadNrrd{"type", "type: uint8", "type: short", 0, "type 'short' is not supported"},
        BadNrrd{"no type", "type: uint8\n", "", 0, "required field 'type' is missing"},
        BadNrrd{"dimension", "dimension: 3", "dimension: 2", 0, "dimension '2'"},
        BadNrrd{"encoding", "encoding: raw", "encoding: gzip", 0, "encoding 'gzip'"},
        BadNrrd{"sizes count", "sizes: 4 3 2", "sizes: 4 3", 0, "must be three numbers"},
        BadNrrd{"sizes text", "sizes: 4 3 2", "sizes: 4 x 2", 0, "'x' is not a whole number"},
        BadNrrd{"sizes zero", "sizes: 4 3 2", "sizes: 4 0 2", 0, "'0' is not a whole number"},
        BadNrrd{"spacing", "spacings: 1 1 1", "spacings: 1 -2 1", 0, "'-2' is not a positive"},
        BadNrrd{"detached", "encoding: raw", "encoding: raw\ndata file: x.raw", 0, "detached data"},
        BadNrrd{"byte skip", "encoding: raw", "encoding: raw\nbyte skip: 8", 0, "'byte skip' = 8"},
        BadNrrd{"twice", "dimension: 3", "dimension: 3\ndimension: 3", 0, "appears twice"},
        BadNrrd{"garbage line", "kinds:", "kinds", 0, "is neither a field"},
        BadNrrd{"truncated", "", "", -5, "truncated: 19 of the 24 data bytes"},
        BadNrrd{"extra data", "", "", 3, "3 bytes after the 24 data bytes"},
        BadNrrd{"sizes larger than data", "sizes: 4 3 2", "sizes: 4 3 3", 0, "truncated"}),
    [](const auto& bad) {
      std::string name = bad.param.name;
      for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      }
      return name;
    });

// Issue F5: a 70-byte header claiming 65536 x 65536 x 1 voxels is refused from the file's size
// before anything is allocated (it used to reserve 4 GiB first). The child may not have 1 GiB.
TEST(Nrrd, HugeSizesInATinyFileAreRefusedBeforeAllocating) {
  if (test_support::kSanitized) {
    GTEST_SKIP() << "a data-size limit breaks the sanitizer's shadow memory";
  }
  ScratchDir dir;
  const std::string header =
      "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 65536 65536 1\nencoding: raw\n\n";
  testing::write_bytes(dir / "huge.nrrd", {header.begin(), header.end()});
  std::string message;
  const test_support::ChildOutcome outcome = test_support::run_in_child(
      [&] {
        try {
          read_nrrd_file(dir / "huge.nrrd");
        } catch (const InputFileError& e) {
          return std::string(e.what()).find("truncated: 0 of the 4294967296 data bytes") !=
                 std::string::npos;
        }
        return false;
      },
      {std::chrono::seconds(20), std::uint64_t{1} << 30});
  EXPECT_EQ(outcome, test_support::ChildOutcome::passed) << to_string(outcome);
}

// Issue F6: a FIFO or a device as an input file is refused at once.
TEST(Nrrd, AFifoOrADeviceIsRefusedAtOnce) {
  ScratchDir dir;
  ASSERT_EQ(::mkfifo((dir / "fifo.nrrd").c_str(), 0600), 0);
  const test_support::ChildOutcome outcome = test_support::run_in_child([&] {
    return message_of([&] { read_nrrd_file(dir / "fifo.nrrd"); }).find("a FIFO") !=
           std::string::npos;
  });
  EXPECT_EQ(outcome, test_support::ChildOutcome::passed) << to_string(outcome);
  const std::string zero = message_of([] { read_nrrd_file("/dev/zero"); });
  EXPECT_NE(zero.find("/dev/zero: it is a character device"), std::string::npos) << zero;
}

// Issue F11: header text in a message is shown printable and shortened, with the file's name.
TEST(Nrrd, MessagesQuoteHeaderBytesPrintableAndShort) {
  ScratchDir dir;
  std::string text = "NRRD0004\ntype: \x01\x02" + std::string(5000, 'v') + "\n\n";
  testing::write_bytes(dir / "noisy.nrrd", {text.begin(), text.end()});
  const std::string message = message_of([&] { read_nrrd_file(dir / "noisy.nrrd"); });
  EXPECT_NE(message.find("noisy.nrrd"), std::string::npos) << message;
  EXPECT_NE(message.find("\\x01\\x02vvv"), std::string::npos) << message;
  EXPECT_LT(message.size(), 400u) << message;
  for (const char c : message) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << int(c);
}

// Issue F6/F11: a calibration file must be a regular file, and a bad value in it is reported with
// the file's name (it used to read as "invalid option").
TEST(CalibrationFile, BadValuesNameTheFileAndAFifoIsRefused) {
  ScratchDir dir;
  const std::string text = "0, 1, x\x07yz\n";
  testing::write_bytes(dir / "cal.txt", {text.begin(), text.end()});
  const std::string message = message_of([&] { read_calibration_file(dir / "cal.txt"); });
  EXPECT_NE(message.find("cal.txt: "), std::string::npos) << message;
  ASSERT_EQ(::mkfifo((dir / "cal.fifo").c_str(), 0600), 0);
  const test_support::ChildOutcome outcome = test_support::run_in_child([&] {
    return message_of([&] { read_calibration_file(dir / "cal.fifo"); }).find("a FIFO") !=
           std::string::npos;
  });
  EXPECT_EQ(outcome, test_support::ChildOutcome::passed) << to_string(outcome);
}

TEST(ProgressBar, DrawsInPlaceOnlyWhenEnabled) {
  std::FILE* quiet = std::tmpfile();
  {
    ProgressBar bar(quiet, "job", "items", 10, false);
    bar.update(5);
    bar.finish();
  }
  EXPECT_EQ(std::ftell(quiet), 0);
  std::fclose(quiet);

  std::FILE* shown = std::tmpfile();
  {
    ProgressBar bar(shown, "job", "items", 10, true);
    bar.update(5);
    bar.finish();
  }
  std::rewind(shown);
  char text[512] = {};
  const std::size_t n = std::fread(text, 1, sizeof text - 1, shown);
  std::fclose(shown);
  const std::string drawn(text, n);
  EXPECT_NE(drawn.find("\rjob [###############---------------]  50%  5/10 items"),
            std::string::npos)
      << drawn;
  EXPECT_NE(drawn.find("100%  10/10 items\n"), std::string::npos) << drawn;
}

}  // namespace
}  // namespace ioct::gpu::offline
