// Placement by markers: B-scans land where their markers say, gaps are zeroed, a volume is
// complete at its end marker, an unfinished one is abandoned.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "ioct/gpu/volume/volume_assembler.hpp"
#include "synthetic_spectra.hpp"

namespace ioct::gpu {
namespace {

constexpr std::uint32_t kBscans = 6;
constexpr std::uint32_t kAscans = 5;
constexpr std::uint32_t kDepth = 4;

// A group whose B-scan i is filled with `value_of(marker)` and carries `markers[i]`.
ProcessedGroup group_of(const std::vector<shm::BscanMarker>& markers,
                        std::uint32_t ascans = kAscans) {
  ProcessedGroup g;
  g.bscan_count = static_cast<std::uint32_t>(markers.size());
  g.ascans = ascans;
  g.depth = kDepth;
  g.pixels.resize(g.bscan_count * g.bscan_pixels());
  for (std::uint32_t i = 0; i < g.bscan_count; ++i) {
    g.markers[i] = markers[i];
    const auto value =
        static_cast<std::uint8_t>(10 * (markers[i].volume_index + 1) + markers[i].bscan_in_volume);
    std::ranges::fill(g.bscan(i), value);
  }
  return g;
}

shm::BscanMarker marker(std::uint64_t volume, std::uint32_t bscan) {
  return testing::marker_for(volume, bscan, kBscans, false);
}

struct Completed {
  std::vector<VolumeInfo> infos;
  std::vector<std::vector<std::uint8_t>> first_pixels;  // pixel (b, 0, 0) of each B-scan
};

VolumeAssembler::CompletionHandler recorder(Completed& completed) {
  return [&completed](const Volume& v, const VolumeInfo& info) {
    completed.infos.push_back(info);
    std::vector<std::uint8_t> firsts;
    for (std::uint32_t b = 0; b < v.bscans(); ++b) firsts.push_back(v.at(b, 0, 0));
    completed.first_pixels.push_back(firsts);
  };
}

TEST(VolumeAssembler, PlacesBscansWhereTheirMarkersSay) {
  VolumeAssembler assembler(kBscans, kDepth);
  Completed completed;
  // Out of order within the volume; the end marker comes last.
  const auto r1 =
      assembler.place(group_of({marker(0, 3), marker(0, 0), marker(0, 4)}), recorder(completed));
  EXPECT_EQ(r1.bscans_placed, 3u);
  EXPECT_EQ(r1.volumes_completed, 0u);
  const auto r2 =
      assembler.place(group_of({marker(0, 1), marker(0, 2), marker(0, 5)}), recorder(completed));
  EXPECT_EQ(r2.volumes_completed, 1u);
  ASSERT_EQ(completed.infos.size(), 1u);
  EXPECT_EQ(completed.infos[0].volume_index, 0u);
  EXPECT_TRUE(completed.infos[0].complete());
  EXPECT_EQ(completed.first_pixels[0], (std::vector<std::uint8_t>{10, 11, 12, 13, 14, 15}));
  const Volume& v = assembler.volume();
  EXPECT_EQ(v.bscans(), kBscans);
  EXPECT_EQ(v.ascans(), kAscans);
  EXPECT_EQ(v.depth(), kDepth);
  EXPECT_EQ(v.at(4, kAscans - 1, kDepth - 1), 14);
}

TEST(VolumeAssembler, MissingBscansAreZeroedNotLeftFromTheLastVolume) {
  VolumeAssembler assembler(kBscans, kDepth);
  Completed completed;
  assembler.place(group_of({marker(0, 0), marker(0, 1), marker(0, 2)}), recorder(completed));
  assembler.place(group_of({marker(0, 3), marker(0, 4), marker(0, 5)}), recorder(completed));
  // Volume 1 loses B-scans 1 and 2 (a dropped group).
  assembler.place(group_of({marker(1, 0)}), recorder(completed));
  assembler.place(group_of({marker(1, 3), marker(1, 4), marker(1, 5)}), recorder(completed));
  ASSERT_EQ(completed.infos.size(), 2u);
  EXPECT_FALSE(completed.infos[1].complete());
  EXPECT_EQ(completed.infos[1].bscans_missing, 2u);
  EXPECT_EQ(completed.infos[1].bscans_placed, 4u);
  EXPECT_EQ(completed.first_pixels[1], (std::vector<std::uint8_t>{20, 0, 0, 23, 24, 25}));
  EXPECT_TRUE(std::ranges::all_of(assembler.volume().bscan(2), [](auto p) { return p == 0; }));
}

TEST(VolumeAssembler, AVolumeWithoutItsEndIsAbandonedWhenTheNextBegins) {
  VolumeAssembler assembler(kBscans, kDepth);
  Completed completed;
  assembler.place(group_of({marker(0, 0), marker(0, 1), marker(0, 2)}), recorder(completed));
  const auto r = assembler.place(group_of({marker(1, 0), marker(1, 1)}), recorder(completed));
  EXPECT_EQ(r.volumes_abandoned, 1u);
  EXPECT_TRUE(completed.infos.empty());
  // The end of a volume in the same group as the start of the next: each is seen whole.
  const auto r2 = assembler.place(
      group_of({marker(1, 2), marker(1, 3), marker(1, 4), marker(1, 5), marker(2, 0)}),
      recorder(completed));
  EXPECT_EQ(r2.volumes_completed, 1u);
  ASSERT_EQ(completed.infos.size(), 1u);
  EXPECT_EQ(completed.first_pixels[0], (std::vector<std::uint8_t>{20, 21, 22, 23, 24, 25}));
  EXPECT_EQ(assembler.volume().at(0, 0, 0), 30);  // volume 2 has begun
}

TEST(VolumeAssembler, RejectsLateAndMisfitBscans) {
  VolumeAssembler assembler(kBscans, kDepth);
  Completed completed;
  assembler.place(group_of({marker(0, 0), marker(0, 5)}), recorder(completed));
  // Late for volume 0, which is complete already.
  EXPECT_EQ(assembler.place(group_of({marker(0, 1)}), recorder(completed)).bscans_rejected, 1u);
  // A width change inside a volume.
  assembler.place(group_of({marker(1, 0)}), recorder(completed));
  EXPECT_EQ(
      assembler.place(group_of({marker(1, 1)}, kAscans + 1), recorder(completed)).bscans_rejected,
      1u);
  // A B-scan index beyond the volume.
  EXPECT_EQ(assembler.place(group_of({marker(1, kBscans)}), recorder(completed)).bscans_rejected,
            1u);
  // A new volume may have a new width.
  const auto r =
      assembler.place(group_of({marker(2, 0), marker(2, 5)}, kAscans + 1), recorder(completed));
  EXPECT_EQ(r.bscans_placed, 2u);
  EXPECT_EQ(assembler.volume().ascans(), kAscans + 1);
  EXPECT_EQ(completed.infos.back().volume_index, 2u);
}

TEST(VolumeAssembler, SealPartialZeroesTheRestAndResetForgets) {
  VolumeAssembler assembler(kBscans, kDepth);
  EXPECT_FALSE(assembler.seal_partial());
  assembler.place(group_of({marker(4, 2), marker(4, 3)}), {});
  const std::optional<VolumeInfo> info = assembler.seal_partial();
  ASSERT_TRUE(info);
  EXPECT_EQ(info->volume_index, 4u);
  EXPECT_EQ(info->bscans_placed, 2u);
  EXPECT_EQ(assembler.volume().at(0, 0, 0), 0);
  EXPECT_EQ(assembler.volume().at(2, 0, 0), 52);
  assembler.place(group_of({marker(5, 0)}), {});
  EXPECT_TRUE(assembler.reset());
  EXPECT_FALSE(assembler.reset());
  EXPECT_FALSE(assembler.seal_partial());
}

}  // namespace
}  // namespace ioct::gpu
