// The selection networks on their own, for every input that can tell a wrong network from a right
// one: all 0/1 inputs (the 0-1 principle: a comparator network that sorts or selects correctly
// for every 0/1 input does so for every input), then random values with and without ties.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <random>

#include "ioct/gpu/filters/median_networks.hpp"

namespace ioct::gpu::filters {
namespace {

TEST(MedianNetworks, Sort9SortsEveryZeroOneInput) {
  for (std::uint32_t bits = 0; bits < (1u << 9); ++bits) {
    std::uint8_t v[9];
    for (int i = 0; i < 9; ++i) v[i] = (bits >> i) & 1u;
    sort9(v);
    ASSERT_TRUE(std::is_sorted(v, v + 9)) << "input bits " << bits;
    ASSERT_EQ(std::count(v, v + 9, 1), std::popcount(bits));
  }
}

TEST(MedianNetworks, MergeGivesTheMiddleTenOfEverySortedZeroOnePair) {
  for (int ones_x = 0; ones_x <= 9; ++ones_x) {
    for (int ones_y = 0; ones_y <= 9; ++ones_y) {
      std::uint8_t x[9], y[9], middle[10];
      for (int i = 0; i < 9; ++i) {
        x[i] = i >= 9 - ones_x;
        y[i] = i >= 9 - ones_y;
      }
      merge9_middle10(x, y, middle);
      std::array<std::uint8_t, 18> all{};
      std::copy(x, x + 9, all.begin());
      std::copy(y, y + 9, all.begin() + 9);
      std::sort(all.begin(), all.end());
      for (int r = 0; r < 10; ++r) {
        ASSERT_EQ(middle[r], all[r + 4]) << ones_x << " + " << ones_y << " ones, rank " << r + 4;
      }
    }
  }
}

TEST(MedianNetworks, MergeOfRandomSortedRunsGivesTheirMiddleTen) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> level(0, 255);
  for (int trial = 0; trial < 20000; ++trial) {
    std::uint8_t x[9], y[9], middle[10];
    const int levels = trial % 2 == 0 ? 256 : 3;
    for (int i = 0; i < 9; ++i) {
      x[i] = static_cast<std::uint8_t>(level(rng) % levels);
      y[i] = static_cast<std::uint8_t>(level(rng) % levels);
    }
    std::sort(x, x + 9);
    std::sort(y, y + 9);
    std::array<std::uint8_t, 18> all{};
    std::copy(x, x + 9, all.begin());
    std::copy(y, y + 9, all.begin() + 9);
    std::sort(all.begin(), all.end());
    merge9_middle10(x, y, middle);
    for (int r = 0; r < 10; ++r) ASSERT_EQ(middle[r], all[r + 4]) << "trial " << trial;
  }
}

// Random values, half of the trials with only a few distinct levels, so ties are everywhere.
class Median27 : public ::testing::Test {
 protected:
  std::array<std::uint8_t, 27> next_values() {
    std::array<std::uint8_t, 27> values{};
    const int levels = trial_++ % 2 == 0 ? 256 : 1 + static_cast<int>(rng_() % 4);
    for (std::uint8_t& v : values) v = static_cast<std::uint8_t>(rng_() % levels);
    return values;
  }
  static std::uint8_t sorted_median(std::array<std::uint8_t, 27> values) {
    std::sort(values.begin(), values.end());
    return values[13];
  }

 private:
  std::mt19937 rng_{11};
  int trial_ = 0;
};

TEST_F(Median27, ForgetfulSelectionEqualsSorting) {
  for (int trial = 0; trial < 100000; ++trial) {
    const auto values = next_values();
    std::uint8_t scratch[27];
    std::copy(values.begin(), values.end(), scratch);
    ASSERT_EQ(median27_forgetful(scratch), sorted_median(values)) << "trial " << trial;
  }
}

TEST_F(Median27, ForgetfulSelectionOfEachRankOneOnes) {
  // 0/1 inputs with k ones: the median is 1 exactly when k >= 14, wherever the ones are.
  std::mt19937 rng(3);
  for (int ones = 0; ones <= 27; ++ones) {
    for (int trial = 0; trial < 2000; ++trial) {
      std::uint8_t v[27] = {};
      std::fill(v, v + ones, 1);
      std::shuffle(v, v + 27, rng);
      ASSERT_EQ(median27_forgetful(v), ones >= 14 ? 1 : 0) << ones << " ones";
    }
  }
}

TEST_F(Median27, SortedRunsEqualSorting) {
  for (int trial = 0; trial < 100000; ++trial) {
    const auto values = next_values();
    std::uint8_t below[9], centre[9], above[9];
    std::copy(values.begin(), values.begin() + 9, below);
    std::copy(values.begin() + 9, values.begin() + 18, centre);
    std::copy(values.begin() + 18, values.end(), above);
    ASSERT_EQ(median27_sorted_runs(below, centre, above), sorted_median(values))
        << "trial " << trial;
  }
}

TEST_F(Median27, SortedRunsOfEachCountOfOnes) {
  std::mt19937 rng(5);
  for (int ones = 0; ones <= 27; ++ones) {
    for (int trial = 0; trial < 2000; ++trial) {
      std::uint8_t v[27] = {};
      std::fill(v, v + ones, 1);
      std::shuffle(v, v + 27, rng);
      std::uint8_t below[9], centre[9], above[9];
      std::copy(v, v + 9, below);
      std::copy(v + 9, v + 18, centre);
      std::copy(v + 18, v + 27, above);
      ASSERT_EQ(median27_sorted_runs(below, centre, above), ones >= 14 ? 1 : 0) << ones;
    }
  }
}

}  // namespace
}  // namespace ioct::gpu::filters
