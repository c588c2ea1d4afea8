// The 2-D views of a volume and the PNG files they are written to.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>

#include "ioct/gpu/volume/png_file.hpp"
#include "ioct/gpu/volume/projections.hpp"

namespace ioct::gpu {
namespace {

namespace fs = std::filesystem;

class ImageOutput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("ioct-gpu-image-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Files in the directory, hidden temporaries included.
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename());
    std::ranges::sort(names);
    return names;
  }

  fs::path dir_;
};

Volume numbered_volume(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth) {
  Volume v(bscans, ascans, depth);
  for (std::uint32_t b = 0; b < bscans; ++b) {
    for (std::uint32_t a = 0; a < ascans; ++a) {
      for (std::uint32_t d = 0; d < depth; ++d) {
        v.bscan(b)[std::size_t{a} * depth + d] = static_cast<std::uint8_t>(b * 50 + a * 10 + d);
      }
    }
  }
  return v;
}

TEST_F(ImageOutput, BscanImageHasDepthVerticalAndAscansHorizontal) {
  const Volume v = numbered_volume(3, 4, 5);
  const GrayImage image = bscan_image(v, 2);
  ASSERT_EQ(image.width, 4u);
  ASSERT_EQ(image.height, 5u);
  for (std::uint32_t a = 0; a < 4; ++a) {
    for (std::uint32_t d = 0; d < 5; ++d) EXPECT_EQ(image.at(a, d), v.at(2, a, d));
  }
}

TEST_F(ImageOutput, EnfaceProjectsAlongDepth) {
  const Volume v = numbered_volume(3, 4, 5);
  const GrayImage max = enface_image(v, EnfaceProjection::max);
  ASSERT_EQ(max.width, 4u);
  ASSERT_EQ(max.height, 3u);
  EXPECT_EQ(max.at(1, 2), 2 * 50 + 1 * 10 + 4);
  const GrayImage mean = enface_image(v, EnfaceProjection::mean);
  // The means are b * 50 + a * 10 + 2, from 2 to 132: stretched to 0..255.
  EXPECT_EQ(mean.at(0, 0), 0);
  EXPECT_EQ(mean.at(3, 2), 255);
  EXPECT_EQ(mean.at(1, 1), (60 * 255 + 65) / 130);
}

TEST_F(ImageOutput, ClippedFractionsCountPixelsAtBothEnds) {
  Volume v(2, 3, 10);  // 60 pixels
  std::ranges::fill(v.bscan(0), std::uint8_t{0});
  std::ranges::fill(v.bscan(1), std::uint8_t{128});
  v.bscan(1)[0] = 255;
  v.bscan(1)[7] = 255;
  v.bscan(1)[8] = 254;
  v.bscan(0)[3] = 1;
  const ClippedFractions clipped = clipped_fractions(v);
  EXPECT_DOUBLE_EQ(clipped.zero, 29.0 / 60.0);
  EXPECT_DOUBLE_EQ(clipped.saturated, 2.0 / 60.0);
}

TEST_F(ImageOutput, PngRoundTripKeepsEveryByte) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  GrayImage image{37, 23, {}};
  for (std::size_t i = 0; i < 37 * 23; ++i)
    image.pixels.push_back(static_cast<std::uint8_t>(byte(rng)));
  const fs::path path = dir_ / "x.png";
  write_png_gray8(path, image);
  const GrayImage back = read_png_gray8(path);
  EXPECT_EQ(back.width, 37u);
  EXPECT_EQ(back.height, 23u);
  EXPECT_EQ(back.pixels, image.pixels);
  EXPECT_EQ(entries(), std::vector<std::string>{"x.png"}) << "a temporary file was left";

  // Overwriting replaces the file whole.
  GrayImage other{3, 2, {1, 2, 3, 4, 5, 6}};
  write_png_gray8(path, other);
  EXPECT_EQ(read_png_gray8(path).pixels, other.pixels);
  EXPECT_EQ(entries(), std::vector<std::string>{"x.png"});
}

TEST_F(ImageOutput, PngErrorsNameThePathAndLeaveNothingBehind) {
  const fs::path missing_dir = dir_ / "no-such-dir" / "x.png";
  try {
    write_png_gray8(missing_dir, 2, 2, std::vector<std::uint8_t>(4, 9));
    FAIL() << "wrote into a missing directory";
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find((dir_ / "no-such-dir").string()), std::string::npos) << message;
    EXPECT_NE(message.find("No such file or directory"), std::string::npos) << message;
  }
  EXPECT_THROW(write_png_gray8(dir_ / "y.png", 2, 2, std::vector<std::uint8_t>(5, 9)),
               std::invalid_argument);
  EXPECT_TRUE(entries().empty());

  std::ofstream(dir_ / "fake.png") << "not a png at all";
  try {
    (void)read_png_gray8(dir_ / "fake.png");
    FAIL() << "read a file that is not a PNG";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("fake.png"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ioct::gpu
