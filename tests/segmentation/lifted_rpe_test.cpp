// Bruch's membrane beneath lifted RPE (lifted_rpe.hpp) on B-scans of known shape: a hump over a
// flat membrane is cut down to the membrane, flat and bowl-shaped membranes stay as they are, an
// A-scan without a BM stays without one, and the windows' medians are those of sorting.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "ioct/gpu/segmentation/lifted_rpe.hpp"

namespace ioct::seg_test {
namespace {

namespace detail = gpu::segmentation::detail;

// The default geometry's settings: 11.7 um between A-scans, 5.6 um per px.
const detail::MembraneSettings kSettings = detail::membrane_settings(6000.0 / 512, 5.6);
constexpr int kAscans = 512;

std::vector<float> membrane_of(const std::vector<float>& finished) {
  const int n = static_cast<int>(finished.size());
  std::vector<float> bm(finished.size()), smoothed(finished.size()), floor(finished.size()),
      next(finished.size());
  detail::membrane_of_bscan(finished.data(), n, kSettings, bm.data(), smoothed.data(), floor.data(),
                            next.data());
  return bm;
}

TEST(LiftedRpe, SettingsFollowTheSampling) {
  EXPECT_EQ(kSettings.median_reach, 6);  // 72 um
  EXPECT_EQ(kSettings.clip_reach, 18);   // 216 um
  EXPECT_NEAR(kSettings.lift_px, 12.0 / 5.6, 1e-6);
}

TEST(LiftedRpe, AHumpIsCutDownToTheMembraneBeneathIt) {
  // Depth grows downwards: the RPE lifted 12 px over 30 A-scans (350 um) above a membrane at 300.
  std::vector<float> finished(kAscans, 300.0f);
  for (int a = 0; a < kAscans; ++a) {
    const double x = (a - 250) / 10.0;
    finished[a] -= static_cast<float>(12.0 * std::exp(-x * x));
  }
  const std::vector<float> bm = membrane_of(finished);
  for (int a = 200; a <= 300; ++a) {
    const float lift = 300.0f - finished[a];
    // Clearly lifted: on the membrane; at the hump's flanks, lifted less than the threshold, the
    // finished BM may stay, never further off than that.
    if (lift > kSettings.lift_px + 1.0f) {
      EXPECT_NEAR(bm[a], 300.0f, 1.0f) << "A-scan " << a;
    }
    EXPECT_NEAR(bm[a], 300.0f, kSettings.lift_px + 0.5f) << "A-scan " << a;
  }
  EXPECT_NEAR(bm[250], 300.0f, 0.5f);
  // Away from the hump the BM is the finished one, untouched.
  for (int a = 0; a < 200; ++a) ASSERT_EQ(bm[a], finished[a]) << "A-scan " << a;
}

TEST(LiftedRpe, FlatAndBowlShapedMembranesStayAsTheyAre) {
  std::vector<float> flat(kAscans, 310.5f);
  EXPECT_EQ(membrane_of(flat), flat);
  // Deepest in the middle (a bowl, as a B-scan through the fovea's curvature may be): the chords
  // lie above it, nothing is clipped.
  std::vector<float> bowl(kAscans);
  for (int a = 0; a < kAscans; ++a) {
    const float x = static_cast<float>(a - 256);
    bowl[a] = 350.0f - 0.0005f * x * x;
  }
  EXPECT_EQ(membrane_of(bowl), bowl);
  // A tilted membrane with a little noise: nothing above the lift threshold either.
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.0f, 0.4f);
  std::vector<float> tilted(kAscans);
  for (int a = 0; a < kAscans; ++a) tilted[a] = 280.0f + 0.05f * static_cast<float>(a) + noise(rng);
  EXPECT_EQ(membrane_of(tilted), tilted);
}

TEST(LiftedRpe, AnAscanWithoutABmStaysWithoutOne) {
  std::vector<float> finished(kAscans, 300.0f);
  for (int a = 240; a < 260; ++a) finished[a] = 290.0f;  // lifted 10 px
  finished[250] = NAN;
  const std::vector<float> bm = membrane_of(finished);
  EXPECT_TRUE(std::isnan(bm[250]));
  EXPECT_NEAR(bm[245], 300.0f, 1.0f);
  std::vector<float> none(kAscans, NAN);
  for (const float v : membrane_of(none)) ASSERT_TRUE(std::isnan(v));
}

TEST(LiftedRpe, WindowMediansAreThoseOfSorting) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> depth(200.0f, 400.0f);
  constexpr int kRow = 40;
  std::vector<float> row(kRow);
  for (int trial = 0; trial < 300; ++trial) {
    for (float& v : row) v = rng() % 5 == 0 ? NAN : std::round(depth(rng) * 4.0f) / 4.0f;
    const int reach = 1 + static_cast<int>(rng() % detail::kMaxMedianReach);
    for (int a = 0; a < kRow; ++a) {
      std::vector<float> window;
      for (int k = std::max(0, a - reach); k <= std::min(kRow - 1, a + reach); ++k) {
        if (!std::isnan(row[k])) window.push_back(row[k]);
      }
      const float median = detail::bm_median_at(row.data(), kRow, a, reach);
      if (window.empty()) {
        ASSERT_TRUE(std::isnan(median)) << "trial " << trial << ", A-scan " << a;
        continue;
      }
      std::sort(window.begin(), window.end());
      const std::size_t n = window.size();
      const float expected =
          n % 2 == 1 ? window[n / 2] : 0.5f * (window[n / 2 - 1] + window[n / 2]);
      ASSERT_EQ(median, expected) << "trial " << trial << ", A-scan " << a << ", reach " << reach;
    }
  }
}

}  // namespace
}  // namespace ioct::seg_test
