// JPEG encoding in bands on several threads: the joined file decodes to exactly the pixels of the
// same image encoded whole, for colour and grey, sizes that do and do not fill the last band, and
// a cut the size of the live renders; bands that cannot be joined are refused by name.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

#include "decoded_jpeg.hpp"
#include "ioct/gpu/live_stages/banded_jpeg_encoder.hpp"

namespace ioct::gpu::live {
namespace {

// A picture with smooth gradients, edges and noise, so every band codes something different.
std::vector<std::uint8_t> picture(std::uint32_t width, std::uint32_t height, unsigned channels,
                                  unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> noise(-20, 20);
  std::vector<std::uint8_t> p(std::size_t{width} * height * channels);
  for (std::uint32_t y = 0; y < height; ++y) {
    for (std::uint32_t x = 0; x < width; ++x) {
      for (unsigned c = 0; c < channels; ++c) {
        int v = static_cast<int>((x * (c + 1) + y * 2) % 256);
        if ((x / 37 + y / 23) % 2 == 0) v = 255 - v;
        v += noise(random);
        p[(std::size_t{y} * width + x) * channels + c] =
            static_cast<std::uint8_t>(c == 3 ? 255 : std::clamp(v, 0, 255));
      }
    }
  }
  return p;
}

struct Case {
  std::uint32_t width, height;
  PixelLayout layout;
  unsigned channels;
  unsigned bands;
};

TEST(BandedJpeg, DecodesToTheSamePixelsAsOneEncodedWhole) {
  const Case cases[] = {
      {1024, 768, PixelLayout::rgba, 4, 4},  // the live render: 4 bands of 192 rows
      {333, 250, PixelLayout::rgb, 3, 4},    // the last band shorter, the width no MCU multiple
      {100, 77, PixelLayout::gray, 1, 3},    // grey: 8 x 8 blocks
      {640, 40, PixelLayout::rgb, 3, 8},     // fewer MCU rows than bands: 3 bands
      {64, 16, PixelLayout::rgba, 4, 4},     // one MCU row: encoded whole
  };
  unsigned seed = 1;
  for (const Case& c : cases) {
    SCOPED_TRACE(testing::Message() << c.width << "x" << c.height << ", " << c.bands << " bands");
    const std::vector<std::uint8_t> p = picture(c.width, c.height, c.channels, seed++);
    JpegEncoder whole(85);
    const std::span<const std::byte> reference = whole.encode(p, c.width, c.height, c.layout);
    const DecodedJpeg expected = decode_jpeg(reference);
    WorkerPool pool(2);
    BandedJpegEncoder banded(85, c.bands, pool);
    const std::span<const std::byte> joined = banded.encode(p, c.width, c.height, c.layout);
    const DecodedJpeg got = decode_jpeg(joined);
    ASSERT_EQ(got.width, static_cast<int>(c.width));
    ASSERT_EQ(got.height, static_cast<int>(c.height));
    ASSERT_FALSE(got.pixels.empty());
    EXPECT_TRUE(got.pixels == expected.pixels) << "the banded JPEG decodes differently";
    // Again with the same encoder: its buffers are reused, the result the same.
    const std::vector<std::byte> first(joined.begin(), joined.end());
    const std::span<const std::byte> again = banded.encode(p, c.width, c.height, c.layout);
    EXPECT_TRUE(std::equal(again.begin(), again.end(), first.begin(), first.end()));
  }
}

TEST(BandedJpeg, OneBandIsThePlainEncoding) {
  const std::vector<std::uint8_t> p = picture(256, 128, 3, 7);
  JpegEncoder whole(85);
  const std::span<const std::byte> plain = whole.encode(p, 256, 128, PixelLayout::rgb);
  WorkerPool pool(1);
  BandedJpegEncoder banded(85, 1, pool);
  const std::span<const std::byte> one = banded.encode(p, 256, 128, PixelLayout::rgb);
  EXPECT_TRUE(std::equal(plain.begin(), plain.end(), one.begin(), one.end()));
}

// Two images cut at once, their bands encoded in one run of the pool in an order that mixes them
// (as the frame publisher encodes a render and a new B-scan): each decodes as encoded alone.
TEST(BandedJpeg, TwoImagesBandsSharingOneRunDecodeAsEachAlone) {
  const std::vector<std::uint8_t> render = picture(1024, 768, 4, 11);
  const std::vector<std::uint8_t> bscan = picture(512, 688, 3, 12);
  JpegEncoder whole(85);
  const DecodedJpeg render_alone = decode_jpeg(whole.encode(render, 1024, 768, PixelLayout::rgba));
  const DecodedJpeg bscan_alone = decode_jpeg(whole.encode(bscan, 512, 688, PixelLayout::rgb));
  WorkerPool pool(3);
  BandedJpegEncoder render_encoder(85, 4, pool), bscan_encoder(85, 4, pool);
  for (int round = 0; round < 2; ++round) {  // the second with the encoders' buffers reused
    const std::uint32_t render_bands = render_encoder.cut(render, 1024, 768, PixelLayout::rgba);
    const std::uint32_t bscan_bands = bscan_encoder.cut(bscan, 512, 688, PixelLayout::rgb);
    ASSERT_EQ(render_bands, 4u);
    ASSERT_EQ(bscan_bands, 4u);
    pool.run(render_bands + bscan_bands, [&](std::uint32_t k, unsigned) {
      // Interleaved, from the last: B-scan 3, render 3, B-scan 2, ...
      const std::uint32_t band = 3 - k / 2;
      (k % 2 == 0 ? bscan_encoder : render_encoder).encode_band(band);
    });
    const DecodedJpeg render_got = decode_jpeg(render_encoder.joined());
    const DecodedJpeg bscan_got = decode_jpeg(bscan_encoder.joined());
    ASSERT_FALSE(render_got.pixels.empty());
    ASSERT_FALSE(bscan_got.pixels.empty());
    EXPECT_TRUE(render_got.pixels == render_alone.pixels) << "round " << round;
    EXPECT_TRUE(bscan_got.pixels == bscan_alone.pixels) << "round " << round;
  }
  // Out of turn: a band past the cut, a join with nothing cut.
  EXPECT_EQ(render_encoder.cut(render, 1024, 768, PixelLayout::rgba), 4u);
  EXPECT_THROW(render_encoder.encode_band(4), std::logic_error);
  for (std::uint32_t k = 0; k < 4; ++k) render_encoder.encode_band(k);
  EXPECT_FALSE(render_encoder.joined().empty());
  EXPECT_THROW(render_encoder.joined(), std::logic_error);
  // A band missing: no JPEG joined from another image's leftovers.
  EXPECT_EQ(render_encoder.cut(render, 1024, 768, PixelLayout::rgba), 4u);
  for (std::uint32_t k = 0; k < 3; ++k) render_encoder.encode_band(k);
  EXPECT_THROW(render_encoder.joined(), std::logic_error);
}

TEST(BandedJpeg, BandsThatCannotBeJoinedAreRefused) {
  const std::vector<std::uint8_t> p = picture(128, 64, 3, 3);
  JpegEncoder q85(85);
  JpegEncoder q50(50);
  const std::size_t half = std::size_t{128} * 32 * 3;
  const std::span<const std::byte> a =
      q85.encode(std::span(p).first(half), 128, 32, PixelLayout::rgb);
  const std::span<const std::byte> b =
      q50.encode(std::span(p).subspan(std::size_t{128} * 32 * 3), 128, 32, PixelLayout::rgb);
  std::vector<std::byte> out;
  const std::span<const std::byte> mixed[] = {a, b};
  try {
    join_jpeg_bands(mixed, 64, 16, out);
    ADD_FAILURE() << "bands of two qualities were joined";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("band 1"), std::string::npos) << e.what();
  }
  const std::vector<std::byte> garbage(100, std::byte{0x42});
  const std::span<const std::byte> bad[] = {a, garbage};
  EXPECT_THROW(join_jpeg_bands(bad, 64, 16, out), std::invalid_argument);
  const std::span<const std::byte> cut[] = {a.first(a.size() - 3), a};
  EXPECT_THROW(join_jpeg_bands(cut, 64, 16, out), std::invalid_argument);
  const std::span<const std::byte> fine[] = {a, a};
  EXPECT_THROW(join_jpeg_bands(fine, 64, 0, out), std::invalid_argument);
  WorkerPool pool(1);
  EXPECT_THROW(BandedJpegEncoder(85, 0, pool), std::invalid_argument);
}

}  // namespace
}  // namespace ioct::gpu::live
